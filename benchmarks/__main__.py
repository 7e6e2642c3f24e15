"""Run every benchmark module found in this package (except tools that set ``RUN_WITH_ALL = False``),
each in a fresh Python process (``python -m benchmarks.NAME``): one benchmark's threads, heap and
garbage-collector state never weigh on the next one's CPU-time measurements."""

import importlib
import pkgutil
import subprocess
import sys
from pathlib import Path

import benchmarks

ROOT = Path(__file__).resolve().parent.parent


def main() -> None:
    failed: list[str] = []
    for info in sorted(pkgutil.iter_modules(benchmarks.__path__), key=lambda m: m.name):
        if info.name.startswith("_"):
            continue
        mod = importlib.import_module(f"benchmarks.{info.name}")
        if hasattr(mod, "main") and getattr(mod, "RUN_WITH_ALL", True):
            print(f"== benchmarks.{info.name}", flush=True)
            done = subprocess.run([sys.executable, "-m", f"benchmarks.{info.name}"], cwd=ROOT)
            if done.returncode:
                failed.append(info.name)
    if failed:
        raise SystemExit(f"benchmarks that failed: {', '.join(failed)}")


if __name__ == "__main__":
    main()
