"""Rewrite the stored numbers of the golden cases (all, or those named) after a change that is meant to
change results; prints what moved.

    .venv/bin/python tests/regression/update_golden.py [case ...]
"""

from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import golden  # noqa: E402


def main(names: list[str]) -> int:
    unknown = sorted(set(names) - set(golden.CASES))
    if unknown:
        print(f"unknown case(s) {unknown}; the cases are {sorted(golden.CASES)}", file=sys.stderr)
        return 2
    golden.STORE.mkdir(exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        for name in names or sorted(golden.CASES):
            now = golden.run_case(name, Path(tmp))
            path = golden.STORE / f"{name}.json"
            if path.exists():
                moved = golden.differences(now, golden.stored(name))
                print(f"{name}: {len(moved)} numbers moved", *moved[:20], sep="\n  ")
            path.write_text(json.dumps(now, indent=1, sort_keys=True) + "\n")
            print(f"{name}: {len(now)} numbers written to {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
