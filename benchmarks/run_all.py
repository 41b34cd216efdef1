"""`make bench`: run every benchmarks/bench_*.py; each prints one JSON object per line.

Each script runs in its own process (so one failing does not hide the others); its JSON
lines go to stdout, progress and errors to stderr. Exit code 1 if any script failed.
"""
from __future__ import annotations

import glob
import os
import subprocess
import sys


def main() -> int:
    here = os.path.dirname(os.path.abspath(__file__))
    only = sys.argv[1:]
    failed = []
    for path in sorted(glob.glob(os.path.join(here, "bench_*.py"))):
        name = os.path.basename(path)[len("bench_"):-3]
        if only and name not in only:
            continue
        print(f"[bench] {name}", file=sys.stderr, flush=True)
        r = subprocess.run([sys.executable, path], stdout=subprocess.PIPE, text=True)
        for line in r.stdout.splitlines():
            if line.startswith("{"):
                print(line, flush=True)
            else:
                print(line, file=sys.stderr)
        if r.returncode != 0:
            failed.append(name)
            print(f"[bench] {name} failed with exit code {r.returncode}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
