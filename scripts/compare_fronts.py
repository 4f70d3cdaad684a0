#!/usr/bin/env python3
"""Compares the Pareto fronts (mean linear P99 against Pd) of two study CSV files case by case.

usage: compare_fronts.py A.csv B.csv [--label-a paper] [--label-b adaptive] [--svg FILE]

Prints, per case, each front (P99 [µm], Pd [%], set) and how many points of one front a point of
the other dominates (lower or equal P99 and higher or equal Pd, one of them strictly), and the area
each front dominates within the box P99 <= 5 µm, Pd >= 95 %. Standard library only.
"""
import argparse
import csv
from collections import defaultdict

P99_LIMIT, PD_FLOOR = 5.0, 95.0


def rows(path):
    by_case = defaultdict(list)
    with open(path, newline="") as f:
        for r in csv.DictReader(f):
            if r["status"] != "ok" or not r["P99_linear"] or not r["Pd"]:
                continue
            by_case[r["case"]].append((float(r["P99_linear"]), float(r["Pd"]), r["set"]))
    return by_case


def front(points):
    best, out = -1.0, []
    for p99, pd, s in sorted(points, key=lambda x: (x[0], -x[1])):
        if pd > best:
            out.append((p99, pd, s))
            best = pd
    return out


def dominates(a, b):
    return a[0] <= b[0] and a[1] >= b[1] and (a[0] < b[0] or a[1] > b[1])


def area(fr):
    """Area of the box [0, P99_LIMIT] x [PD_FLOOR, 100] that the front dominates."""
    total, prev_pd = 0.0, PD_FLOOR
    for p99, pd, _ in fr:  # by P99 ascending, Pd ascending
        if p99 >= P99_LIMIT or pd <= prev_pd:
            continue
        total += (P99_LIMIT - p99) * (min(pd, 100.0) - prev_pd)
        prev_pd = pd
    return total


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("a")
    ap.add_argument("b")
    ap.add_argument("--label-a", default="A")
    ap.add_argument("--label-b", default="B")
    ap.add_argument("--svg", help="also draw both fronts per case into this SVG file")
    ap.add_argument("--title", default="")
    args = ap.parse_args()
    ra, rb = rows(args.a), rows(args.b)
    print(f"| case | front {args.label_a} (P99 µm / Pd %) | front {args.label_b} (P99 µm / Pd %) | "
          f"{args.label_a} points dominated by {args.label_b} | {args.label_b} points dominated by {args.label_a} | "
          f"area {args.label_a} | area {args.label_b} |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for case in sorted(set(ra) | set(rb)):
        fa, fb = front(ra.get(case, [])), front(rb.get(case, []))
        da = sum(any(dominates(q, p) for q in fb) for p in fa)
        db = sum(any(dominates(q, p) for q in fa) for p in fb)
        show = lambda fr: " ".join(f"{p:.2f}/{d:.2f}" for p, d, _ in fr if p < 8)
        print(f"| {case} | {show(fa)} | {show(fb)} | {da} of {len(fa)} | {db} of {len(fb)} | "
              f"{area(fa):.2f} | {area(fb):.2f} |")
    if args.svg:
        svg(args.svg, args.title, ra, rb, args.label_a, args.label_b)


def svg(path, title, ra, rb, la, lb):
    cases = sorted(set(ra) | set(rb))
    w, h, cols = 420, 320, 2
    rows_n = (len(cases) + cols - 1) // cols
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{w * cols}" height="{h * rows_n + 40}" '
           f'font-family="sans-serif" font-size="12">',
           f'<text x="10" y="22" font-size="15">{title}</text>']
    colours = {la: "#1f77b4", lb: "#d62728"}
    for k, case in enumerate(cases):
        x0, y0 = (k % cols) * w + 60, (k // cols) * h + 60
        pw, ph = w - 90, h - 90
        pd_lo, pd_hi, p_lo, p_hi = 95.0, 99.0, 1.5, 5.5
        X = lambda pd: x0 + (pd - pd_lo) / (pd_hi - pd_lo) * pw
        Y = lambda p: y0 + ph - (p - p_lo) / (p_hi - p_lo) * ph
        out.append(f'<rect x="{x0}" y="{y0}" width="{pw}" height="{ph}" fill="none" stroke="#888"/>')
        out.append(f'<text x="{x0 + pw - 60}" y="{y0 - 6}" font-weight="bold">case {case}</text>')
        for v in (95, 96, 97, 98, 99):
            out.append(f'<text x="{X(v) - 8:.1f}" y="{y0 + ph + 16}">{v}</text>')
        for v in (2, 3, 4, 5):
            out.append(f'<text x="{x0 - 20}" y="{Y(v) + 4:.1f}">{v}</text>')
        out.append(f'<text x="{x0 + pw / 2 - 20}" y="{y0 + ph + 32}">Pd [%]</text>')
        out.append(f'<text x="{x0 - 45}" y="{y0 - 6}">P99 [µm]</text>')
        for label, data in ((la, ra), (lb, rb)):
            fr = [(p, d) for p, d, _ in front(data.get(case, [])) if pd_lo <= d <= pd_hi and p_lo <= p <= p_hi]
            if fr:
                pts = " ".join(f"{X(d):.1f},{Y(p):.1f}" for p, d in fr)
                out.append(f'<polyline points="{pts}" fill="none" stroke="{colours[label]}" stroke-width="2"/>')
                for p, d in fr:
                    out.append(f'<circle cx="{X(d):.1f}" cy="{Y(p):.1f}" r="3" fill="{colours[label]}"/>')
        for i, label in enumerate((la, lb)):
            out.append(f'<text x="{x0 + 8}" y="{y0 + 16 + 14 * i}" fill="{colours[label]}">{label}</text>')
    out.append("</svg>")
    with open(path, "w") as f:
        f.write("\n".join(out) + "\n")


if __name__ == "__main__":
    main()
