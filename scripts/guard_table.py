#!/usr/bin/env python3
"""Per-output P99 with ALC against uncompensated, with and without the guard (docs/adaptive.md).

Runs `alc replay --case X --seed S --json` for A-D at seeds 1-6, H1-H5 and S16 (their own
seeds) once per set of extra options and prints, per recording, the mean linear P99, Pd and the
outputs whose P99 with ALC exceeds the uncompensated P99 (by more than --tolerance).

  python3 scripts/guard_table.py --alc build/rel/cli/alc --set 'no guard=--guard off' --set 'guard='
"""
import argparse
import json
import subprocess
import sys

LINEAR = ("E_X0C", "E_Y0C", "E_Z0T", "E_R0T", "E_X", "E_Y", "E_Z")


def is_linear(name):
    return not (name.startswith("E_A") or name.startswith("E_B") or name.startswith("E_C"))


def replay(alc, case, seed, extra):
    cmd = [alc, "replay", "--case", case, "--json"] + (["--seed", str(seed)] if seed is not None else []) + extra
    out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
    return json.loads(out)


def figures(result, tolerance):
    outs = result["outputs"]
    lin = [v["P99"] for k, v in outs.items() if is_linear(k)]
    worse = [(k, v["P99"], v["P99_uncompensated"]) for k, v in sorted(outs.items())
             if v["P99"] > v["P99_uncompensated"] + tolerance]
    return sum(lin) / len(lin), result["Pd"], worse


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--alc", default="build/rel/cli/alc")
    ap.add_argument("--set", action="append", required=True,
                    help="label=extra options (space-separated), e.g. 'guard=--guard on'")
    ap.add_argument("--seeds", default="1,2,3,4,5,6")
    ap.add_argument("--cases", default="A,B,C,D")
    ap.add_argument("--others", default="H1,H2,H3,H4,H5,S16", help="cases run at their own seed")
    ap.add_argument("--tolerance", type=float, default=0.0)
    ap.add_argument("--json", help="write every figure to this file")
    a = ap.parse_args()
    sets = []
    for s in a.set:
        label, _, extra = s.partition("=")
        sets.append((label, extra.split()))
    runs = [(c, int(s)) for c in a.cases.split(",") if c for s in a.seeds.split(",") if s]
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
            r = replay(a.alc, case, seed, extra)
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
