#!/usr/bin/env python3
"""Per-output P99 with ALC against uncompensated, with and without the guard (docs/adaptive.md).

Runs `alc replay --case X --seed S --json` for A-D at seeds 1-6, H1-H5 and S16 (their own
seeds) once per set of extra options and prints, per recording, the mean linear P99, Pd and the
outputs whose P99 with ALC exceeds the uncompensated P99 (by more than --tolerance).

  python3 scripts/guard_table.py --set 'no guard=--no-guard' --set 'guard (default)='

--sweep 1|2|3 runs one of the three sets of replays of docs/adaptive.md instead (1: A-D at their own
seeds and 1-12, H1-H5 at theirs and 1-80, S16 at its own and 1-10, 468 replays; 2: A-D at 13-24, H1-H5
at 81-160, S16 at 11-20, 458; 3: A-D at 25-36, H1-H5 at 161-240, S16 at 21-30, 458; 4: A-D at 37-48, H1-H5
at 241-320, S16 at 31-40, 458) and prints per set
of options the mean linear P99 and Pd of A-D, S16 and the held-out cases and every output worse than
uncompensated (--jobs replays at a time):

  python3 scripts/guard_table.py --sweep 3 --jobs 2 --set 'guard (default)='

--sweep h3 runs H3 (the machine moved at 26 h) at seeds 1-240 (its own, 203, among them), 240 replays: with
--set 'move told=--probe-at 26' the probe asked for at the move (docs/adaptive.md, "Probes asked for").

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
from concurrent.futures import ThreadPoolExecutor
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


# The sets of replays of docs/adaptive.md (None: the case's own seed): per case group, its seeds.
def _sweep(ad, held, s16):
    return ([(c, s) for c in "ABCD" for s in ad] + [(c, s) for c in ("H1", "H2", "H3", "H4", "H5") for s in held] +
            [("S16", s) for s in s16])


SWEEPS = {"1": _sweep([None] + list(range(1, 13)), [None] + list(range(1, 81)), [None] + list(range(1, 11))),
          "2": _sweep(range(13, 25), range(81, 161), range(11, 21)),
          "3": _sweep(range(25, 37), range(161, 241), range(21, 31)),
          "4": _sweep(range(37, 49), range(241, 321), range(31, 41)),
          "h3": [("H3", s) for s in range(1, 241)]}


def sweep(alc, runs, sets, jobs, tolerance):
    for label, extra in sets:
        groups = {"A-D": [], "S16": [], "held-out": []}
        worse = []
        with ThreadPoolExecutor(jobs) as pool:
            results = pool.map(lambda run: replay(alc, run[0], run[1], extra), runs)
            for (case, seed), r in zip(runs, results):
                p99, pd, w = figures(r, tolerance)
                group = "A-D" if case in ("A", "B", "C", "D") else ("S16" if case == "S16" else "held-out")
                groups[group].append((p99, pd))
                name = case + (f" s{seed}" if seed is not None else "")
                worse += [f"{name} {k} {p:.3f} > {u:.3f} (+{100 * (p / u - 1):.1f} %)" for k, p, u in w]
        print(f"{label}: " + " / ".join(
            f"{g} {sum(p for p, _ in v) / len(v):.3f} µm, Pd {sum(d for _, d in v) / len(v):.3f} %"
            for g, v in groups.items() if v) + f" over {len(runs)} replays; outputs worse than uncompensated: {len(worse)}")
        for w in worse:
            print(f"  {w}")


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
    ap.add_argument("--sweep", choices=sorted(SWEEPS), help="one of the sets of replays (see above) instead")
    ap.add_argument("--jobs", type=int, default=1, help="replays at a time with --sweep (default 1)")
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
    if a.sweep:
        if a.jobs < 1:
            ap.error(f"--jobs {a.jobs}: give 1 or more")
        return sweep(alc, SWEEPS[a.sweep], sets, a.jobs, a.tolerance)
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
