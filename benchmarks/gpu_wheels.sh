#!/usr/bin/env bash
# Wheels of erosim's dependencies that a CUDA Python image (numpy, numba, numba-cuda, scipy,
# matplotlib, rich, click already there) usually lacks, for installing on a GPU machine without
# network; there: `pip install --no-index --no-deps --target SITE DIR/*.whl`, SITE on PYTHONPATH, then
# `python benchmarks/gpu_session.py OUT` (docs/gpu.md).
#
#   bash benchmarks/gpu_wheels.sh DIR [PYTHON_VERSION]      (default 3.12; x86-64 Linux)
#
# The SPH benchmark and validations import only these (pydantic for the settings, tomli-w for the
# run folder's scenario.toml).
set -euo pipefail
DIR=${1:?give the folder for the wheels}
PYV=${2:-3.12}
mkdir -p "$DIR"
python3 -m pip download --no-deps --only-binary=:all: --python-version "$PYV" --implementation cp \
    --platform manylinux_2_28_x86_64 --platform manylinux_2_17_x86_64 --platform manylinux2014_x86_64 \
    -d "$DIR" \
    "pydantic==2.14.4" "pydantic-core==2.50.5" "annotated-types==0.8.0" "typing-inspection==0.4.5" \
    "typing-extensions==4.16.0" "tomli-w==1.2.0"
ls -la "$DIR"
