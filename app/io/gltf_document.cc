#include "app/io/gltf_document.h"

#include <array>
#include <cmath>
#include <cstring>

#include <nlohmann/json.hpp>

#include "core/field_error.h"

namespace scanbench {
namespace {

// glTF's enumerations (the specification's accessor.componentType,
// bufferView.target and sampler tables).
constexpr int kFloat = 5126, kUnsignedShort = 5123;
constexpr int kArrayBuffer = 34962, kElementArrayBuffer = 34963;
constexpr int kLinear = 9729, kLinearMipmapLinear = 9987, kClampToEdge = 33071;
constexpr int kTriangles = 4;

template <typename T>
void Append(std::vector<uint8_t>* buffer, const T* values, size_t count) {
  const size_t offset = buffer->size();
  buffer->resize(offset + count * sizeof(T));
  std::memcpy(buffer->data() + offset, values, count * sizeof(T));  // glTF is little-endian, as is x86/ARM
}

}  // namespace

void GltfTileOptions::Check() const {
  constexpr char kWhere[] = "GltfTileOptions";
  if (name.empty()) throw FieldError(kWhere, "name", "''", "must not be empty");
  if (!std::isfinite(width_m) || !(width_m > 0)) throw FieldError(kWhere, "width_m", width_m, "must be finite and > 0");
  if (!std::isfinite(height_m) || !(height_m > 0)) {
    throw FieldError(kWhere, "height_m", height_m, "must be finite and > 0");
  }
  for (const auto& [field, uri] : {std::pair{"basecolor_uri", &basecolor_uri}, std::pair{"normal_uri", &normal_uri},
                                   std::pair{"occlusion_roughness_metallic_uri", &occlusion_roughness_metallic_uri},
                                   std::pair{"buffer_uri", &buffer_uri}}) {
    if (uri->empty()) throw FieldError(kWhere, field, "''", "must name a file relative to the .gltf");
  }
}

GltfTileFiles BuildGltfTile(const GltfTileOptions& options) {
  options.Check();
  const float x = static_cast<float>(options.width_m / 2), z = static_cast<float>(options.height_m / 2);
  // Corners: image top-left, bottom-left, bottom-right, top-right.
  const std::array<float, 12> positions = {-x, 0, -z, -x, 0, z, x, 0, z, x, 0, -z};
  const std::array<float, 12> normals = {0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1, 0};
  const std::array<float, 16> tangents = {1, 0, 0, 1, 1, 0, 0, 1, 1, 0, 0, 1, 1, 0, 0, 1};
  const std::array<float, 8> uvs = {0, 0, 0, 1, 1, 1, 1, 0};
  const std::array<uint16_t, 6> indices = {0, 1, 2, 0, 2, 3};  // counter-clockwise seen from +Y

  GltfTileFiles files;
  nlohmann::json buffer_views = nlohmann::json::array();
  nlohmann::json accessors = nlohmann::json::array();
  auto add_view = [&](size_t byte_length, int target) {
    buffer_views.push_back({{"buffer", 0}, {"byteOffset", files.buffer.size() - byte_length},
                            {"byteLength", byte_length}, {"target", target}});
    return static_cast<int>(buffer_views.size() - 1);
  };
  auto add_float_attribute = [&](const float* values, size_t count, int components, const char* type,
                                 nlohmann::json extra = nlohmann::json::object()) {
    Append(&files.buffer, values, count);
    nlohmann::json accessor = {{"bufferView", add_view(count * sizeof(float), kArrayBuffer)},
                               {"componentType", kFloat},
                               {"count", count / components},
                               {"type", type}};
    accessor.update(extra);
    accessors.push_back(accessor);
    return static_cast<int>(accessors.size() - 1);
  };
  const int position = add_float_attribute(positions.data(), positions.size(), 3, "VEC3",
                                           {{"min", {-x, 0, -z}}, {"max", {x, 0, z}}});  // min/max: required
  const int normal = add_float_attribute(normals.data(), normals.size(), 3, "VEC3");
  const int tangent = add_float_attribute(tangents.data(), tangents.size(), 4, "VEC4");
  const int uv = add_float_attribute(uvs.data(), uvs.size(), 2, "VEC2");
  Append(&files.buffer, indices.data(), indices.size());
  accessors.push_back({{"bufferView", add_view(indices.size() * sizeof(uint16_t), kElementArrayBuffer)},
                       {"componentType", kUnsignedShort},
                       {"count", indices.size()},
                       {"type", "SCALAR"}});
  const int index_accessor = static_cast<int>(accessors.size() - 1);

  nlohmann::json gltf;
  gltf["asset"] = {{"version", "2.0"}, {"generator", options.generator}};
  gltf["scene"] = 0;
  gltf["scenes"] = {{{"name", options.name}, {"nodes", {0}}}};
  gltf["nodes"] = {{{"name", options.name}, {"mesh", 0}}};
  gltf["meshes"] = {{{"name", options.name},
                     {"primitives",
                      {{{"attributes", {{"POSITION", position}, {"NORMAL", normal}, {"TANGENT", tangent},
                                        {"TEXCOORD_0", uv}}},
                        {"indices", index_accessor},
                        {"material", 0},
                        {"mode", kTriangles}}}}}};
  // The maps cover one sample, not a repeating tile: clamp at the edges.
  gltf["samplers"] = {{{"magFilter", kLinear}, {"minFilter", kLinearMipmapLinear}, {"wrapS", kClampToEdge},
                       {"wrapT", kClampToEdge}}};
  gltf["images"] = {{{"uri", options.basecolor_uri}}, {{"uri", options.normal_uri}},
                    {{"uri", options.occlusion_roughness_metallic_uri}}};
  gltf["textures"] = {{{"sampler", 0}, {"source", 0}}, {{"sampler", 0}, {"source", 1}},
                      {{"sampler", 0}, {"source", 2}}};
  gltf["materials"] = {{{"name", options.name},
                        {"pbrMetallicRoughness",
                         {{"baseColorTexture", {{"index", 0}}},
                          {"metallicFactor", 0.0},  // a textile is a dielectric; the texture's B is 0 too
                          {"roughnessFactor", 1.0},
                          {"metallicRoughnessTexture", {{"index", 2}}}}},
                        {"normalTexture", {{"index", 1}, {"scale", 1.0}}},
                        {"occlusionTexture", {{"index", 2}, {"strength", 1.0}}}}};
  gltf["accessors"] = accessors;
  gltf["bufferViews"] = buffer_views;
  gltf["buffers"] = {{{"uri", options.buffer_uri}, {"byteLength", files.buffer.size()}}};
  files.json = gltf.dump(2) + "\n";
  return files;
}

}  // namespace scanbench
