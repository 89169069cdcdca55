"""Record what `mirl run` and `mirl learn` print on fixed seeds, to check that a refactoring
changes no result.

    python benchmarks/record_outputs.py OUT_DIR            # record (about two minutes)
    python benchmarks/record_outputs.py OUT_DIR --against BASE_DIR   # record and compare

Timings are the only part of an output that may differ between two runs of the same code, so
they are removed: the ``timings`` key of the JSON forms and the ``time``/``timings`` lines of the
text reports.
Every other byte must match.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

SEEDS = range(10)


def commands(work: Path) -> dict[str, list[str]]:
    """Output name -> the mirl command line that produces it."""
    out: dict[str, list[str]] = {}
    for k in SEEDS:
        out[f"run-{k}.json"] = ["run", "--obs-steps", "300", "--seed", f"{k}", "--json"]
        out[f"run-default-{k}.txt"] = ["run", "--seed", f"{k}"]
        out[f"run-dbn-em-{k}.json"] = [
            "run", "--method", "dbn-em", "--observability", "0.5", "--obs-steps", "300",
            "--seed", f"{k}", "--json",
        ]  # fmt: skip
        out[f"run-known-r-t-boydright-{k}.json"] = [
            "run", "--scenario", "boydright", "--method", "known-r-t", "--obs-steps", "200",
            "--seed", f"{k}", "--json",
        ]  # fmt: skip
        out[f"learn-{k}.json"] = [
            "learn", "--scenario", "boyd2", "--observations", f"obs-{k}.csv", "--json",
        ]  # fmt: skip
        out[f"learn-{k}.txt"] = [
            "learn", "--scenario", "boyd2", "--observations", f"obs-{k}.csv",
        ]  # fmt: skip
    for k in range(3):
        out[f"run-physics-{k}.json"] = [
            "run", "--world", "physics", "--obs-steps", "300", "--seed", f"{k}", "--json",
        ]  # fmt: skip
    return out


def normalised(name: str, text: str) -> str:
    """The output without its timings."""
    if name.endswith(".json"):
        data = json.loads(text)
        data.pop("timings", None)
        return json.dumps(data, indent=1, sort_keys=True) + "\n"
    return "".join(
        line for line in text.splitlines(True) if not line.startswith(("time ", "timings "))
    )


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--against", type=Path, help="a directory recorded earlier")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        for k in SEEDS:
            subprocess.run(
                [sys.executable, "-m", "mirl", "simulate", "--scenario", "boyd2", "--steps",
                 "450", "--seed", f"{k}", "--observations", f"obs-{k}.csv"],
                check=True, capture_output=True, cwd=work,
            )  # fmt: skip

        def record(item: tuple[str, list[str]]) -> None:
            name, argv = item
            done = subprocess.run(
                [sys.executable, "-m", "mirl", *argv], capture_output=True, text=True, cwd=work
            )
            text = f"exit {done.returncode}\n{done.stderr}" if done.returncode else done.stdout
            (args.out / name).write_text(normalised(name, text) if not done.returncode else text)

        with ThreadPoolExecutor(2) as pool:
            list(pool.map(record, commands(work).items()))
    if args.against is None:
        return 0
    names = sorted({p.name for p in args.out.iterdir()} | {p.name for p in args.against.iterdir()})
    differ = [
        n for n in names
        if not (args.out / n).exists() or not (args.against / n).exists()
        or (args.out / n).read_bytes() != (args.against / n).read_bytes()
    ]  # fmt: skip
    print(f"{len(names) - len(differ)} of {len(names)} outputs byte-identical")
    for n in differ:
        print(f"  differs: {n}")
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
