// The lobes of the engines a scan is exported to, in one place for the
// simulator (app/sim) and the cloth material fit (solver/cloth_material.h):
// glTF 2.0's and UE4's GGX with the height-correlated Smith visibility and
// Schlick's Fresnel, and the Charlie sheen of the Enterprise PBR model and
// KHR_materials_sheen (Estevez and Kulla 2017) with Neubelt and Pettineo's
// visibility, which KHR_materials_sheen names as the cheaper alternative to
// Charlie's own.
#pragma once

namespace scanbench {

// Schlick's Fresnel: f0 + (1 - f0) (1 - cos)^5, cos clamped to [0, 1].
double SchlickFresnel(double f0, double cos_theta);

// GGX's distribution D(h) for alpha (glTF: roughness^2) and cos_h = n.h.
double GgxDistribution(double alpha, double cos_h);
// The height-correlated Smith visibility G / (4 n.l n.v) of GGX (glTF's V).
double GgxVisibility(double alpha, double nl, double nv);

// Charlie's distribution (2 + 1/a) sin(th_h)^(1/a) / (2 pi), a = roughness^2 as
// KHR_materials_sheen; roughness clamped below so that a >= 1e-3.
double CharlieDistribution(double roughness, double cos_h);
// The sheen visibility of Neubelt and Pettineo, 1 / (4 (n.l + n.v - n.l n.v)).
double SheenVisibility(double nl, double nv);
// Directional albedo of Charlie sheen of colour 1 at roughness r and cos of
// the direction to the normal mu (the E of KHR_materials_sheen's albedo
// scaling), from a table integrated numerically once. In [0, 1].
double CharlieSheenAlbedo(double mu, double roughness);

}  // namespace scanbench
