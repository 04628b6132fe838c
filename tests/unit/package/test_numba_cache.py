"""Compiled kernels are cached in a folder named by a hash of the package's sources, so an edited
file can never be served from a stale cache (Numba keys a cached caller by its own file only)."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import erosim

PKG = Path(erosim.__file__).resolve().parent


def test_any_source_edit_changes_the_cache_folder(tmp_path):
    copy = tmp_path / "erosim"
    shutil.copytree(PKG, copy, ignore=shutil.ignore_patterns("__pycache__", "*.csv", "*.toml", "*.md"))
    before = erosim.source_hash(copy)
    assert before == erosim.source_hash(PKG)
    callee = copy / "sph" / "boundaries" / "box.py"  # a file whose functions other files' kernels inline
    callee.write_text(callee.read_text() + "\n# an edit\n")
    assert erosim.source_hash(copy) != before


def test_the_cache_folder_is_used_by_numba(tmp_path):
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["XDG_CACHE_HOME"] = str(tmp_path)
    code = "import numba, erosim; print(numba.config.CACHE_DIR)"
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    expected = tmp_path / "erosim" / "numba" / f"{erosim.__version__}-{erosim.source_hash(PKG)}"
    assert out.stdout.strip() == str(expected) and expected.is_dir()
    # numba imported first (its configuration read before erosim's): the folder is still used
    code = "import numba; import erosim; print(numba.config.CACHE_DIR)"
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == str(expected)


def test_a_user_cache_dir_is_a_root_under_which_the_hashed_folder_is_used(tmp_path):
    """NUMBA_CACHE_DIR set by the user names the root; the folder below it still carries the hash, so
    an edit is never served from a stale cache there either (and a child process, which inherits the
    resolved folder, does not nest it again)."""
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["NUMBA_CACHE_DIR"] = str(tmp_path / "mine")
    expected = tmp_path / "mine" / f"{erosim.__version__}-{erosim.source_hash(PKG)}"
    code = (
        "import os, subprocess, sys, numba, erosim; print(numba.config.CACHE_DIR); "
        "print(subprocess.run([sys.executable, '-c', 'import numba, erosim; print(numba.config.CACHE_DIR)'],"
        " capture_output=True, text=True, check=True).stdout.strip())"
    )
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.split() == [str(expected), str(expected)] and expected.is_dir()
