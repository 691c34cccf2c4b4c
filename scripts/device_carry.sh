#!/usr/bin/env bash
# What a device call carries besides the checkout (docs/scale.md "The scaling study on a GPU"): the GPU image
# has Python 3.12 with torch, Lightning, numpy, pandas, matplotlib and scikit-image, but not Mitsuba, Dr.Jit,
# Hydra, OmegaConf, OpenEXR or FLIP. This script builds, in .carry/ (git-ignored through .git/info/exclude):
#
#   .carry/site312.tar.xz   those packages' cp312 manylinux wheels unpacked into one site folder, Mitsuba slimmed
#                           to its rgb variants (cuda_ad_rgb, scalar_rgb) and the plugins the scenes use, so that
#                           the checkout and the carry stay under the call's 64 MiB (about 21 MB)
#   .carry/scenes.tar.xz    the scenes of SCENES (default: small's scenes that are not vendored) from
#                           SCENES_DIR (default ../shared/scenes)
#
# The device command then begins with
#   mkdir -p /tmp/site /tmp/scenes && tar -xJf .carry/site312.tar.xz -C /tmp/site &&
#   tar -xJf .carry/scenes.tar.xz -C /tmp/scenes && export PYTHONPATH=/tmp/site MCD_SCENES_DIR=/tmp/scenes
# and names .carry in the call's carry list.
set -euo pipefail
cd "$(dirname "$0")/.."
SCENES=${SCENES:-bathroom veach-ajar}
SCENES_DIR=${SCENES_DIR:-../shared/scenes}
PY=${PY:-python3}
grep -qx '/.carry/' .git/info/exclude 2>/dev/null || echo '/.carry/' >>.git/info/exclude
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p .carry "$tmp/wheels" "$tmp/site"
platforms=()
for p in manylinux_2_28_x86_64 manylinux_2_27_x86_64 manylinux_2_17_x86_64 manylinux2014_x86_64; do
  platforms+=(--platform "$p")
done
"$PY" -m pip download -q --no-deps --only-binary=:all: --python-version 3.12 --implementation cp \
  "${platforms[@]}" -d "$tmp/wheels" mitsuba==3.9.1 drjit==1.3.1 hydra-core==1.3.2 omegaconf==2.3.0 \
  "OpenEXR>=3.3" "flip-evaluator>=1.7"
"$PY" -m pip wheel -q --no-deps -w "$tmp/wheels" antlr4-python3-runtime==4.9.3   # Hydra's; an sdist only
for w in "$tmp"/wheels/*.whl; do
  "$PY" -m zipfile -e "$w" "$tmp/site"
done
m=$tmp/site/mitsuba
rm -rf "$m"/include "$m"/cmake "$m"/pkgconfig "$m"/mitsuba_stubs "$m"/python/test "$m"/*.pyi \
  "$m"/data/srgb.coeff "$m"/data/sunsky
find "$m" -maxdepth 1 -name '*.so' \( -name '*mono*' -o -name '*spectral*' -o -name 'llvm_ad_*' \) -delete
for p in ellipsoids volpathmis ellipsoidsmesh volpath bsplinecurve sdfgrid sunsky timed_sunsky ptracer hair \
         measured_polarized measured pplastic linearcurve projector gridvolume thinlens principledthin specfilm \
         polarizer irradiancemeter radiancemeter blender orthographic cylinder blendphase; do
  rm -f "$m/plugins/$p.so"
done
tar -cJf .carry/site312.tar.xz -C "$tmp/site" .
read -r -a scenes <<<"$SCENES"
tar -cJf .carry/scenes.tar.xz -C "$SCENES_DIR" "${scenes[@]}"
ls -la .carry
