#!/usr/bin/env python3
"""Offline data preparation: writes data/spectra/*.csv from a colour-science checkout.

Usage:
    python3 scripts/data/extract_spectra.py [--colour-repo DIR] [--out DIR]

The tables are read from the Python sources of colour-science (parsed with `ast`, the package is never
imported) at the commit given by --commit, and resampled to the grid scanbench embeds: 380 .. 780 nm in
5 nm steps (81 samples). Resampling is linear interpolation; outside a table's range the end value is held
(what colour-science's default constant extrapolator does). Only the Python standard library is needed.
"""

import argparse
import ast
import os
import subprocess
import sys

FIRST_NM, STEP_NM, SAMPLES = 380, 5, 81
GRID = [FIRST_NM + STEP_NM * i for i in range(SAMPLES)]
COLOUR_COMMIT = "9d743142ed97a5cfae347b559aca14c43464eb70"
COLOUR_URL = "https://github.com/colour-science/colour"
COLOUR_LICENCE = "BSD-3-Clause (colour-science: Copyright 2013 Colour Developers)"

CHART_ORDER = [
    "dark skin", "light skin", "blue sky", "foliage", "blue flower", "bluish green",
    "orange", "purplish blue", "moderate red", "purple", "yellow green", "orange yellow",
    "blue", "green", "red", "yellow", "magenta", "cyan",
    "white 9.5 (.05 D)", "neutral 8 (.23 D)", "neutral 6.5 (.44 D)", "neutral 5 (.70 D)",
    "neutral 3.5 (1.05 D)", "black 2 (1.5 D)",
]


def read_source(repo, commit, path):
    """The file's text at `commit`: from a bare mirror (git show) or a work tree."""
    try:
        return subprocess.run(["git", "-C", repo, "show", f"{commit}:{path}"], check=True,
                              capture_output=True, text=True).stdout
    except (subprocess.CalledProcessError, FileNotFoundError):
        with open(os.path.join(repo, path), encoding="utf-8") as f:
            return f.read()


def module_literal(source, name):
    """The literal assigned to the module-level `name` (np.array(x) gives x)."""
    for node in ast.parse(source).body:
        targets = []
        if isinstance(node, ast.Assign):
            targets, value = node.targets, node.value
        elif isinstance(node, ast.AnnAssign):
            targets, value = [node.target], node.value
        if any(isinstance(t, ast.Name) and t.id == name for t in targets):
            if isinstance(value, ast.Call):  # np.array([...])
                value = value.args[0]
            return ast.literal_eval(value)
    raise KeyError(f"{name} not found")


def resample(table):
    """table: {wavelength: value} -> values on GRID (linear, end values held outside)."""
    xs = sorted(float(k) for k in table)
    ys = [float(table[k]) for k in sorted(table, key=float)]
    out = []
    for w in GRID:
        if w <= xs[0]:
            out.append(ys[0])
        elif w >= xs[-1]:
            out.append(ys[-1])
        else:
            j = next(i for i in range(1, len(xs)) if xs[i] >= w)
            t = (w - xs[j - 1]) / (xs[j] - xs[j - 1])
            out.append(ys[j - 1] + t * (ys[j] - ys[j - 1]))
    return out


def columns_of(table, count):
    """{wavelength: (a, b, c)} -> count resampled columns."""
    return [resample({w: v[c] for w, v in table.items()}) for c in range(count)]


def write_csv(path, comments, header, columns):
    with open(path, "w", encoding="utf-8", newline="\n") as f:
        for line in comments:
            f.write(f"# {line}\n")
        f.write(",".join(["wavelength_nm"] + header) + "\n")
        for i, w in enumerate(GRID):
            f.write(",".join([str(w)] + [f"{col[i]:.10g}" for col in columns]) + "\n")


def provenance(path, name):
    return [f"Taken from colour-science {COLOUR_URL} commit {COLOUR_COMMIT},",
            f"file {path}, {name}.",
            f"Licence as stated there: {COLOUR_LICENCE}.",
            "Resampled to 380..780 nm, 5 nm, by scripts/data/extract_spectra.py "
            "(linear interpolation, end values held)."]


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--colour-repo", default="/work/.mirror/colour-science+colour/repo")
    parser.add_argument("--commit", default=COLOUR_COMMIT)
    parser.add_argument("--out", default=os.path.join(os.path.dirname(__file__), "..", "..", "data", "spectra"))
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)

    def source(path):
        return read_source(args.colour_repo, args.commit, path)

    path = "colour/colorimetry/datasets/cmfs.py"
    name = "CIE 1931 2 Degree Standard Observer"
    cmfs = module_literal(source(path), "DATA_CMFS_STANDARD_OBSERVER")[name]
    write_csv(os.path.join(args.out, "cie1931_2deg_cmf.csv"),
              ["CIE 1931 2-degree standard observer colour matching functions x-bar, y-bar, z-bar.",
               "Original source: CIE 15:2004 / CIE 015:2018 Colorimetry, doi:10.25039/TR.015.2018;",
               "tabulated by CVRL (http://cvrl.ioo.ucl.ac.uk/cie.htm)."]
              + provenance(path, f'DATA_CMFS_STANDARD_OBSERVER["{name}"] (1 nm)'),
              ["x_bar", "y_bar", "z_bar"], columns_of(cmfs, 3))

    path = "colour/colorimetry/datasets/illuminants/sds.py"
    illuminants = module_literal(source(path), "DATA_ILLUMINANTS_CIE")
    write_csv(os.path.join(args.out, "cie_d65.csv"),
              ["CIE standard illuminant D65, relative spectral power distribution (560 nm = 100).",
               "Original source: CIE 15:2004 tables; CIE 015:2018 Colorimetry, doi:10.25039/TR.015.2018."]
              + provenance(path, 'DATA_ILLUMINANTS_CIE["D65"]'),
              ["d65"], [resample(illuminants["D65"])])
    write_csv(os.path.join(args.out, "cie_d50.csv"),
              ["CIE illuminant D50, relative spectral power distribution (560 nm = 100).",
               "Original source: CIE 15:2004 tables; CIE 015:2018 Colorimetry, doi:10.25039/TR.015.2018."]
              + provenance(path, 'DATA_ILLUMINANTS_CIE["D50"]'),
              ["d50"], [resample(illuminants["D50"])])
    write_csv(os.path.join(args.out, "cie_led_b5.csv"),
              ["CIE illuminant LED-B5: phosphor-converted blue LED white, CCT 6598 K, relative SPD.",
               "Original source: CIE 015:2018 Colorimetry, 4th edition, doi:10.25039/TR.015.2018",
               "(CIE spectral data, http://files.cie.co.at/204.xls)."]
              + provenance(path, 'DATA_ILLUMINANTS_CIE["LED-B5"]'),
              ["led_b5"], [resample(illuminants["LED-B5"])])

    path = "colour/characterisation/datasets/cameras/dslr/sensitivities.py"
    nikon = module_literal(source(path), "DATA_CAMERA_SENSITIVITIES_DSLR")["Nikon 5100 (NPL)"]
    write_csv(os.path.join(args.out, "nikon_d5100_npl.csv"),
              ["Nikon D5100 camera spectral sensitivities R, G, B (relative), measured at NPL.",
               "Original source: Darrodi, Finlayson, Goodman & Mackiewicz (2015), Reference data set for",
               "camera spectral sensitivity estimation, JOSA A 32(3) 381, doi:10.1364/JOSAA.32.000381."]
              + provenance(path, 'DATA_CAMERA_SENSITIVITIES_DSLR["Nikon 5100 (NPL)"]'),
              ["red", "green", "blue"], columns_of(nikon, 3))

    path = "colour/characterisation/datasets/colour_checkers/sds.py"
    babel = module_literal(source(path), "DATA_BABELCOLOR_AVERAGE")
    missing = [n for n in CHART_ORDER if n not in babel]
    if missing:
        sys.exit(f"DATA_BABELCOLOR_AVERAGE lacks patches {missing}")
    write_csv(os.path.join(args.out, "colorchecker_babelcolor_avg.csv"),
              ["X-Rite ColorChecker Classic, 24 patch spectral reflectances (0..1), BabelColor average",
               "of 30 charts, columns in chart order (row by row from dark skin, gray row last).",
               "Original source: Pascale, D., BabelColor ColorChecker data,",
               "http://www.babelcolor.com/download/ColorChecker_RGB_and_spectra.xls",
               "(Copyright (C) 2004-2012 Danny Pascale, used by permission in colour-science).",
               "Measured 380..730 nm at 10 nm; 735..780 nm hold the 730 nm value."]
              + provenance(path, "DATA_BABELCOLOR_AVERAGE"),
              CHART_ORDER, [resample(babel[n]) for n in CHART_ORDER])

    path = "colour/recovery/datasets/mallett2019.py"
    basis = module_literal(source(path), "DATA_BASIS_FUNCTIONS_sRGB_MALLETT2019")
    if len(basis) != SAMPLES:
        sys.exit(f"Mallett 2019 basis has {len(basis)} rows, expected {SAMPLES} (380..780 nm, 5 nm)")
    write_csv(os.path.join(args.out, "mallett2019_srgb_basis.csv"),
              ["Mallett & Yuksel (2019) sRGB spectral primary basis: reflectance = r*red + g*green + b*blue",
               "for linear sRGB (r, g, b) in [0, 1]; the three sum to 1 at every wavelength.",
               "Original source: Mallett, I. & Yuksel, C. (2019), Spectral Primary Decomposition for",
               "Rendering with sRGB Reflectance, EGSR DL-only track, doi:10.2312/SR.20191216."]
              + provenance(path, "DATA_BASIS_FUNCTIONS_sRGB_MALLETT2019 (already 380..780 nm, 5 nm)"),
              ["red", "green", "blue"],
              [[row[c] for row in basis] for c in range(3)])


if __name__ == "__main__":
    main()
