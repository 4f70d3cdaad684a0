#!/usr/bin/env python3
"""Per-output P99 with ALC against uncompensated, with and without the guard (docs/adaptive.md).

Runs `alc replay --case X --seed S --json` for A-D at seeds 1-6, H1-H5 and S16 (their own
seeds) once per set of extra options and prints, per recording, the mean linear P99, Pd and the
outputs whose P99 with ALC exceeds the uncompensated P99 (by more than --tolerance).

  python3 scripts/guard_table.py --set 'no guard=--no-guard' --set 'guard (default)='

--alc defaults to build/release/cli/alc of this checkout (the build of scripts/main.sh), wherever the
script is run from.
"""
import argparse
import json
import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

# The release build of scripts/main.sh, beside this script's checkout (not relative to the cwd).
DEFAULT_ALC = Path(__file__).resolve().parent.parent / "build" / "release" / "cli" / "alc"

LINEAR = ("E_X0C", "E_Y0C", "E_Z0T", "E_R0T", "E_X", "E_Y", "E_Z")


def is_linear(name):
    return not (name.startswith("E_A") or name.startswith("E_B") or name.startswith("E_C"))


def replay(alc, case, seed, extra):
    cmd = [alc, "replay", "--case", case, "--json"] + (["--seed", str(seed)] if seed is not None else []) + extra
    text = shlex.join(cmd)
    try:
        run = subprocess.run(cmd, capture_output=True, text=True)
    except OSError as e:  # FileNotFoundError, PermissionError, ...
        raise SystemExit(f"{text}: {e.strerror or e}")
    if run.returncode != 0:
        raise SystemExit(f"{text}: {run.stderr.strip() or f'exit status {run.returncode}, no output on stderr'}")
    try:
        return json.loads(run.stdout)
    except json.JSONDecodeError as e:
        raise SystemExit(f"{text}: its output is not JSON ({e})")


def figures(result, tolerance):
    outs = result["outputs"]
    lin = [v["P99"] for k, v in outs.items() if is_linear(k)]
    worse = [(k, v["P99"], v["P99_uncompensated"]) for k, v in sorted(outs.items())
             if v["P99"] > v["P99_uncompensated"] + tolerance]
    return sum(lin) / len(lin), result["Pd"], worse


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--alc", default=str(DEFAULT_ALC),
                    help="the alc binary (default: build/release/cli/alc of this checkout, from scripts/main.sh)")
    ap.add_argument("--set", action="append", required=True,
                    help="label=extra options (space-separated), e.g. 'no guard=--no-guard'; empty: the defaults")
    ap.add_argument("--seeds", default="1,2,3,4,5,6", help="seeds of --cases, comma-separated whole numbers")
    ap.add_argument("--cases", default="A,B,C,D")
    ap.add_argument("--others", default="H1,H2,H3,H4,H5,S16", help="cases run at their own seed")
    ap.add_argument("--tolerance", type=float, default=0.0)
    ap.add_argument("--json", help="write every figure to this file")
    a = ap.parse_args()
    # A bare name (--alc alc) is looked up on PATH, as subprocess would; a path must be there.
    alc = shutil.which(a.alc) if "/" not in a.alc else (a.alc if os.path.isfile(a.alc) else None)
    if alc is None:
        hint = " (build it with scripts/main.sh, or give --alc PATH)" if a.alc == str(DEFAULT_ALC) else ""
        ap.error(f"no alc binary at {a.alc}{hint}")
    sets = []
    for s in a.set:
        label, eq, extra = s.partition("=")
        if not eq or not label:
            ap.error(f"--set {s!r}: give LABEL=OPTIONS (OPTIONS may be empty, e.g. 'guard (default)=')")
        sets.append((label, extra.split()))
    seeds = [s.strip() for s in a.seeds.split(",") if s.strip()]
    bad = [s for s in seeds if not re.fullmatch(r"[0-9]+", s)]
    if bad:
        ap.error(f"--seeds {a.seeds!r}: give whole numbers separated by commas, e.g. 1,2,3 "
                 f"(not {', '.join(map(repr, bad))})")
    cases = [c for c in a.cases.split(",") if c]
    if cases and not seeds:
        ap.error(f"--seeds {a.seeds!r}: no seed for --cases {a.cases} (give --cases '' to run only --others)")
    runs = [(c, int(s)) for c in cases for s in seeds]
    runs += [(c, None) for c in a.others.split(",") if c]
    table = {}
    print("| recording | " + " | ".join(f"{l}: mean lin. P99 [µm], Pd [%]" for l, _ in sets) + " | " +
          " | ".join(f"{l}: outputs worse than uncompensated" for l, _ in sets) + " |")
    print("|" + " --- |" * (1 + 2 * len(sets)))
    totals = {l: {"ad": [], "pd_ad": []} for l, _ in sets}
    for case, seed in runs:
        name = case + (f" s{seed}" if seed is not None else "")
        cells, worse_cells = [], []
        for label, extra in sets:
            r = replay(alc, case, seed, extra)
            p99, pd, worse = figures(r, a.tolerance)
            table.setdefault(name, {})[label] = {"mean_linear_P99": p99, "Pd": pd,
                                                 "outputs": {k: [v["P99"], v["P99_uncompensated"]]
                                                             for k, v in r["outputs"].items()}}
            if case in ("A", "B", "C", "D"):
                totals[label]["ad"].append(p99)
                totals[label]["pd_ad"].append(pd)
            cells.append(f"{p99:.2f}, {pd:.2f}")
            worse_cells.append(", ".join(f"{k} {w:.2f} > {u:.2f}" for k, w, u in worse) or "none")
        print(f"| {name} | " + " | ".join(cells) + " | " + " | ".join(worse_cells) + " |", flush=True)
    for label, _ in sets:
        t = totals[label]
        if t["ad"]:
            print(f"{label}: A-D mean linear P99 {sum(t['ad'])/len(t['ad']):.3f} µm, "
                  f"mean Pd {sum(t['pd_ad'])/len(t['pd_ad']):.3f} % over {len(t['ad'])} runs")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(table, f, indent=1)


if __name__ == "__main__":
    sys.exit(main())
