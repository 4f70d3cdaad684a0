#!/usr/bin/env python3
"""Compares the Pareto fronts (mean linear P99 against Pd) of two study CSV files case by case.

usage: compare_fronts.py A.csv B.csv [--label-a paper] [--label-b adaptive] [--svg PREFIX] [--fronts]
                         [--worse-by PARAM[,PARAM...]] [--choose-on GROUP ...] [--sample-sets N [--seed S]]
                         [--cases CASE[,CASE...]]

A front is the sets no other set of the same file beats in both (lower or equal P99, higher or equal
Pd). Per case (a recording: a built-in case, or a file "X seed S.csv" of scripts/fronts.sh) it prints
- how many points of one front a point of the other dominates (lower or equal P99 and higher or
  equal Pd, one of them strictly);
- the area each front dominates in the box Pd from the lowest Pd of either front to 100 %, P99 from
  0 to 2.5 x the lowest P99 of either front (the part the figures show; larger is better; the same
  box for both fronts);
- along Pd: the best P99 each front reaches at a Pd of at least p, for p over the Pd range of the two
  fronts in steps of 0.01 %; the Pd ranges where B's P99 is lower (B wins) and where A's is (A wins;
  a front that does not reach p has no P99 there and loses). These are where the fronts cross.
  Summed over the cases: the shares of the Pd range each front wins, over the whole range and over
  only the Pd both fronts reach (from the higher of their two lowest Pd up: below it one front has no
  set, and the other wins or loses there by probing more often than the first one's grid allows);
- B's P99 against A's at equal Pd: the mean of (B - A) / A over the Pd both fronts reach (from the
  higher lowest to the lower highest Pd, steps of 0.01 %), which weighs by how much a front is lower,
  not only where; over the cases its mean and median, on how many B is the lower on average, and the
  two-sided p of a sign test of that split (how likely so uneven a split is if neither front were
  the better one).
Then the pooled comparison: per group of recordings (A-D, the held-out cases H1-H5, all; each at the
own seeds, at each other seed and at all seeds together) one point per parameter set, the mean over
the group's recordings of its linear P99 and of its Pd, so a front of sets that a user would set once
for every machine of the group rather than pick per recording in hindsight; the same Pd ranges,
dominated points, shares (both kinds) and P99 at equal Pd as above.
With --worse-by PARAMS, the runs (set x recording) of each file whose mean linear or angular P99 is above
that without compensation, and those with an output whose P99 is (the guard's "never worse", per case
and per output), per value of those parameters.
Both tables pick each front's points from all sets in hindsight, per recording or per group, and a grid
of more sets gains by that alone (each set's P99 has noise; the front keeps the luckiest). Two checks:
with --choose-on GROUP (a group of the pooled table, its name without the count, e.g. "A-D, own seeds";
may be repeated) each file's sets on the front pooled over that group are chosen there, as a user who
tunes on those machines would, and both tables are printed again with only the chosen sets on the
other recordings (out of sample); with --sample-sets N each file keeps N of its sets drawn at random
(random.Random(--seed, default 1); a file of N sets or fewer keeps all), which compares grids of
different size at the same size.
With --cases CASE[,CASE...] only the recordings of those cases count (at every seed), so one study
over all cases gives the tables of a subset (scripts/fronts.sh with CASES="A B C D H7" runs the same rows).
With --svg PREFIX, one SVG per seed (PREFIX-own.svg, PREFIX-seed-S.svg) with both fronts per case.
Standard library only.
"""
import argparse
import csv
import math
import random
import re
from collections import defaultdict


def case_key(name):
    """'A' -> ('A', 'own'); '.../A seed 2.csv' -> ('A', 'seed 2')."""
    base = re.sub(r"\.csv$", "", name.split("/")[-1])
    m = re.match(r"^(.*) seed (\d+)$", base)
    return (m.group(1), f"seed {m.group(2)}") if m else (base, "own")


def recording_name(key):
    """('A', 'own') -> 'A'; ('A', 'seed 2') -> 'A seed 2': a recording as the tables name it."""
    return key[0] if key[1] == "own" else f"{key[0]} {key[1]}"


REQUIRED = ("case", "status", "Pd", "P99_linear")  # the columns of `alc study --csv` read here


def read_study(path):
    """The rows of a study CSV that ran (status ok, P99 and Pd numbers): per row a dict with the
    recording's key (case_key), the set's name (its parameter values: the columns between `case` and
    `status`, not its number, so that the rows of several grids, whose numbers start at 1 each, can
    share one file), its parameters, the linear P99, the Pd, its outputs as (name, P99, P99
    uncompensated) and the case's means (linear and angular P99, each with and without compensation;
    NaN where a cell is empty). A file that is not a study CSV, a row that does not hold the fixed
    columns and whole outputs (a file cut mid-row; a row of another recording's outputs is accepted),
    or a number that is not one ends the script with a message naming the file, line and column."""
    out = []
    try:
        with open(path, newline="") as f:
            reader = csv.reader(f)
            header = next(reader, None)
            if not header:
                raise SystemExit(f"{path}: empty, no header line (not a study CSV of `alc study --csv`)")
            col = {name: i for i, name in enumerate(header)}
            missing = [c for c in REQUIRED if c not in col]
            if missing:
                raise SystemExit(f"{path}:1: not a study CSV of `alc study --csv`: no column "
                                 f"{', '.join(missing)} in its header")
            if col["case"] > col["status"]:
                raise SystemExit(f"{path}:1: not a study CSV of `alc study --csv`: `status` comes before `case`")
            params = header[col["case"] + 1:col["status"]]
            # The columns before the per-output ones (6 per output: PV, RMSE, P99, SMAPE,
            # P99_uncompensated, measurements). fronts.sh joins the rows of every recording under the
            # first part's header, so a recording with other outputs (S16: 5, A-D: 7) has rows of
            # another length; each row must still hold the fixed columns and whole outputs.
            fixed = col["uncompensated_P99_angular"] + 1 if "uncompensated_P99_angular" in col else len(header)
            seen = set()
            for row in reader:
                if not row:
                    continue  # a blank line
                if len(row) < fixed or (len(row) - fixed) % 6 != 0:
                    raise SystemExit(f"{path}:{reader.line_num}: {len(row)} fields, where a row holds {fixed} and 6 per "
                                     f"output (a row cut short, or a file cut mid-row?)")
                r = dict(zip(header[:fixed], row))  # a header repeated inside has status "status": left out below
                if r["status"] != "ok" or not r["P99_linear"] or not r["Pd"]:
                    continue
                def cell(i, what):
                    """The number in field i (what: its name for the message); an empty cell is NaN (not
                    measured, e.g. no angular output); any other text ends the script naming it."""
                    try:
                        return float(row[i]) if row[i] else math.nan
                    except ValueError:
                        raise SystemExit(f"{path}:{reader.line_num}: {what} {row[i]!r} is not a number")
                p99, pd = cell(col["P99_linear"], "P99_linear"), cell(col["Pd"], "Pd")
                if not (math.isfinite(p99) and math.isfinite(pd)):
                    continue  # no point to place (as an empty cell)
                # An output's name from the header where the row has the header's outputs, else its
                # position (a row of a recording with other outputs, joined under another header).
                outputs = []
                for b in range(fixed, len(row), 6):
                    if not any(row[b:b + 6]):
                        continue  # all six cells empty: an output the recording does not have (a study over
                        # recordings with other outputs writes every output of any of them in each row)
                    output = (header[b][:-len("_PV")] if len(row) == len(header) and header[b].endswith("_PV")
                              else f"output {(b - fixed) // 6 + 1}")
                    outputs.append((output, cell(b + 2, f"the P99 of {output}"),
                                    cell(b + 4, f"the uncompensated P99 of {output}")))
                # The case's mean linear and angular P99 with and without compensation (NaN: empty, e.g. no
                # angular output, or a file without the column).
                means = [cell(col[c], c) if c in col else math.nan
                         for c in ("P99_linear", "uncompensated_P99_linear", "P99_angular", "uncompensated_P99_angular")]
                k = case_key(r["case"])
                name = " ".join(f"{p}={r[p]}" for p in params)
                if (k, name) in seen:
                    raise SystemExit(f"{path}:{reader.line_num}: the set {name} ran twice on {r['case']} "
                                     f"(two grids with the same values?)")
                seen.add((k, name))
                out.append({"key": k, "set": name, "params": {p: r[p] for p in params}, "P99": p99, "Pd": pd,
                            "outputs": outputs, "means": means})
    except OSError as e:
        raise SystemExit(f"{path}: {e.strerror or e}")
    except (csv.Error, UnicodeDecodeError) as e:
        raise SystemExit(f"{path}: not a readable CSV file ({e})")
    return out


def rows(records):
    """Per recording, (P99, Pd, set) of the rows of read_study."""
    by_case = defaultdict(list)
    for r in records:
        by_case[r["key"]].append((r["P99"], r["Pd"], r["set"]))
    return by_case


def case_worse(record):
    """Whether the case's mean linear or mean angular P99 with ALC is above that without compensation."""
    lin, lin_u, ang, ang_u = record["means"]
    return lin > lin_u or ang > ang_u


def worse(record):
    """The outputs of a row whose P99 with ALC is above their P99 without compensation."""
    return [name for name, p99, uncompensated in record["outputs"] if p99 > uncompensated]


def value_order(text):
    """Numbers first, by value (inf last of them), then the other texts."""
    try:
        return (0, float(text), text)
    except ValueError:
        return (1, 0.0, text)


def worse_table(files, by):
    """Markdown lines: per file and per value of the parameters `by` (a parameter a file lacks: "—"), the
    rows (set x recording), those whose case is worse than uncompensated (its mean linear or angular P99),
    those with an output worse than uncompensated, and the recordings these are on."""
    lines = [f"| schedule | {' | '.join(by) if by else 'sets'} | runs | runs whose mean linear or angular P99 is "
             f"worse than uncompensated | runs with an output worse than uncompensated | outputs worse / outputs | "
             f"recordings (runs with an output worse) |",
             "| --- | " + " | ".join("---" for _ in by or [0]) + " | --- | --- | --- | --- | --- |"]
    for label, records in files:
        groups = defaultdict(list)
        for r in records:
            groups[tuple(r["params"].get(b, "—") or "(moot)" for b in by)].append(r)
        for value in sorted(groups, key=lambda v: [value_order(x) for x in v]):
            rs = groups[value]
            worse_outputs = [worse(r) for r in rs]
            where = defaultdict(int)
            for r, w in zip(rs, worse_outputs):
                if w:
                    where[recording_name(r["key"])] += 1
            n_out = sum(len(r["outputs"]) for r in rs)
            n_bad = sum(len(w) for w in worse_outputs)
            text = ", ".join(f"{k} ({n})" for k, n in sorted(where.items())) or "—"
            n_case = sum(case_worse(r) for r in rs)
            lines.append(f"| {label} | {' | '.join(value) if by else 'all'} | {len(rs)} | {n_case} | {sum(map(bool, worse_outputs))} | "
                         f"{n_bad} / {n_out} | {text} |")
    return lines


def pooled(by_case, keys):
    """One point per set that ran (status ok) on every recording of `keys`: its mean P99 and mean Pd over
    them; and how many sets are left out because they did not."""
    runs = defaultdict(dict)
    for k in keys:
        for p99, pd, s in by_case.get(k, []):
            runs[s][k] = (p99, pd)
    points = [(sum(p for p, _ in r.values()) / len(keys), sum(d for _, d in r.values()) / len(keys), s)
              for s, r in runs.items() if len(r) == len(keys)]
    return points, len(runs) - len(points)


def groups(keys):
    """(name, keys) of the pooled comparison: A-D, held-out, all; at each seed and at all seeds."""
    kinds = [("A-D", lambda c: c in ("A", "B", "C", "D")), ("held-out", lambda c: c.startswith("H")),
             ("all", lambda c: True)]
    seeds = sorted({k[1] for k in keys}, key=lambda s: (s != "own", s))
    out = []
    for name, kind in kinds:
        for seed in seeds + ["all seeds"]:
            ks = [k for k in keys if kind(k[0]) and (seed == "all seeds" or k[1] == seed)]
            if ks and not (seed == "all seeds" and len(seeds) == 1):
                out.append((f"{name}, {'own seeds' if seed == 'own' else seed} ({len(ks)})", ks))
    return out


def front(points):
    best, out = -math.inf, []
    for p99, pd, s in sorted(points, key=lambda x: (x[0], -x[1])):
        if pd > best:
            out.append((p99, pd, s))
            best = pd
    return out


def dominates(a, b):
    return a[0] <= b[0] and a[1] >= b[1] and (a[0] < b[0] or a[1] > b[1])


def area(fr, pd_floor, p99_limit):
    """Area of the box [0, p99_limit] x [pd_floor, 100] that the front dominates."""
    total, prev_pd = 0.0, pd_floor
    for p99, pd, _ in fr:  # by P99 ascending, Pd ascending
        if p99 >= p99_limit or pd <= prev_pd:
            continue
        total += (p99_limit - p99) * (min(pd, 100.0) - prev_pd)
        prev_pd = pd
    return total


def best_at(fr, pd):
    """The lowest P99 of the front at a Pd of at least pd (inf: the front does not reach pd)."""
    return min((p for p, d, _ in fr if d >= pd - 1e-9), default=math.inf)


def crossings(fa, fb):
    """Pd ranges (lo, hi, winner) along the union of both fronts' Pd range, winner 'a', 'b' or '='."""
    pds = [d for _, d, _ in fa + fb]
    if not pds:
        return []
    lo, hi = min(pds), max(pds)
    out, n = [], int(round((hi - lo) / 0.01))
    for k in range(n + 1):
        pd = lo + k * 0.01
        a, b = best_at(fa, pd), best_at(fb, pd)
        w = "=" if abs(a - b) < 0.005 or (math.isinf(a) and math.isinf(b)) else ("b" if b < a else "a")
        if out and out[-1][2] == w:
            out[-1][1] = pd
        else:
            out.append([pd, pd, w])
    return out


def duel(fa, fb):
    """How fronts A and B compare: points of A dominated by B, of B by A, per winner ('a', 'b', '=') the
    width and the text of the Pd ranges where it has the lower P99, and per winner the width of those
    at a Pd that both fronts reach: from the higher of their lowest Pd up. Below it the front with the
    higher lowest Pd has no set, its best there is its lowest-Pd point, so the other wins there by
    probing more than the first one's grid allows, not by its P99 at a Pd both reach."""
    da = sum(any(dominates(q, p) for q in fb) for p in fa)
    db = sum(any(dominates(q, p) for q in fa) for p in fb)
    ranges = crossings(fa, fb)
    won = {who: describe(ranges, who) for who in ("a", "b", "=")}
    both = max(min((d for _, d, _ in fr), default=-math.inf) for fr in (fa, fb))
    return da, db, won, {who: won_from(ranges, who, both) for who in won}


def gap(fa, fb):
    """B's P99 against A's at equal Pd, over the Pd both fronts reach (from the higher of their lowest Pd
    to the lower of their highest, in the steps of 0.01 % of crossings): the mean of (B - A) / A in %, and
    the number of steps; (nan, 0) where the two ranges do not meet. Negative: B is the lower on average.
    Unlike the shares, it weighs by how much a front is lower, not only where."""
    if not fa or not fb:
        return math.nan, 0
    lo = max(min(d for _, d, _ in fr) for fr in (fa, fb))
    hi = min(max(d for _, d, _ in fr) for fr in (fa, fb))
    if hi < lo - 1e-9:
        return math.nan, 0
    diffs = []
    for k in range(int(round((hi - lo) / 0.01)) + 1):
        pd = min(lo + k * 0.01, hi)
        a, b = best_at(fa, pd), best_at(fb, pd)
        diffs.append(100.0 * (b - a) / a)
    return sum(diffs) / len(diffs), len(diffs)


def sign_test(lower, n):
    """The two-sided p of a sign test: the chance of a split at least as uneven as `lower` of n if either
    front were as likely as the other to be the lower on average (exact binomial, p = 1/2)."""
    if n == 0:
        return math.nan
    k = min(lower, n - lower)
    return min(1.0, 2.0 * sum(math.comb(n, i) for i in range(k + 1)) / 2 ** n)


def percent(x):
    """A signed percentage with one decimal ('—' for none)."""
    return "—" if math.isnan(x) else f"{x:+.1f} %"


def shares(widths, first, second):
    """'x / y / z %': the shares of widths[first], widths[second] and widths['='] in their sum."""
    total = sum(widths[w] for w in (first, second, "="))
    return " / ".join(f"{100 * widths[w] / total:.1f}" for w in (first, second, "=")) + " %" if total > 0 else "—"


def won_from(ranges, who, pd_from):
    """The width of the Pd ranges that `who` wins at a Pd of pd_from or more (the steps of 0.01 % of
    crossings, each step counted as describe counts it)."""
    steps = 0
    for lo, hi, w in ranges:
        if w == who:
            n = int(round((hi - lo) / 0.01)) + 1
            steps += n - min(n, max(0, math.ceil((pd_from - 1e-9 - lo) / 0.01)))
    return 0.01 * steps


def describe(ranges, who):
    spans = [(lo, hi) for lo, hi, w in ranges if w == who]
    width = sum(hi - lo + 0.01 for lo, hi in spans)
    text = ", ".join(f"{lo:.2f}" if hi - lo < 0.005 else f"{lo:.2f}–{hi:.2f}" for lo, hi in spans)
    return width, text or "—"


def choose(by_case, keys):
    """The sets on the front pooled over `keys`: what a user who tunes on those recordings would choose
    from (one set for every machine of the group), before judging them on others."""
    return {s for _, _, s in front(pooled(by_case, keys)[0])}


def only(by_case, sets):
    """by_case (rows) with only the points of `sets`."""
    return {k: [p for p in v if p[2] in sets] for k, v in by_case.items()}


def sample_sets(records, n, seed):
    """The rows of n of the file's sets drawn at random (random.Random(seed), from its sets by name), or
    all rows where the file has n sets or fewer; and how many sets it had. A front of more sets is
    lower by selection alone (each set's P99 has noise, the front keeps the luckiest), so two grids of
    very different size compare better at the same size."""
    sets = sorted({r["set"] for r in records})
    if len(sets) <= n:
        return records, len(sets)
    pick = set(random.Random(seed).sample(sets, n))
    return [r for r in records if r["set"] in pick], len(sets)


def recording_table(ra, rb, keys, la, lb):
    """The per-recording table and the lines under it (the shares, the P99 at equal Pd over the recordings)."""
    out = [f"| recording | {la} points dominated by {lb} | {lb} points dominated by {la} | area {la} | area {lb} | "
           f"Pd [%] where {lb} has the lower P99 | Pd [%] where {la} has the lower P99 | "
           f"{lb}'s P99 against {la}'s at equal Pd |", "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    wins, commons, gaps = defaultdict(float), defaultdict(float), []
    for k in keys:
        fa, fb = front(ra.get(k, [])), front(rb.get(k, []))
        da, db, won, common = duel(fa, fb)
        floor = min([d for _, d, _ in fa + fb], default=95.0)
        limit = 2.5 * min([p for p, _, _ in fa + fb], default=2.0)
        (wa, ta), (wb, tb) = won["a"], won["b"]
        for who in won:
            wins[who] += won[who][0]
            commons[who] += common[who]
        g, steps = gap(fa, fb)
        if steps:
            gaps.append(g)
        out.append(f"| {recording_name(k)} | {da} of {len(fa)} | {db} of {len(fb)} | {area(fa, floor, limit):.2f} | "
                   f"{area(fb, floor, limit):.2f} | {tb} | {ta} | {percent(g)} |")
    total = sum(wins.values())
    if total > 0:
        out.append(f"\nalong Pd over all {len(keys)} recordings: {lb} lower P99 on {100 * wins['b'] / total:.1f} %, "
                   f"{la} lower on {100 * wins['a'] / total:.1f} %, equal (within 0.005 µm) on "
                   f"{100 * wins['='] / total:.1f} % of the Pd range")
        out.append(f"over the Pd range both fronts reach (from the higher of their lowest Pd up): {lb} / {la} / equal "
                   f"{shares(commons, 'b', 'a')}")
    if gaps:
        lower = sum(g < 0 for g in gaps)
        ordered = sorted(gaps)
        median = (ordered[(len(ordered) - 1) // 2] + ordered[len(ordered) // 2]) / 2
        out.append(f"{lb}'s P99 against {la}'s at equal Pd (over the Pd both reach): mean {percent(sum(gaps) / len(gaps))}, "
                   f"median {percent(median)} over {len(gaps)} recordings, lower on average on {lower} of them, "
                   f"{la}'s on {sum(g > 0 for g in gaps)} (sign test, two-sided: p = {sign_test(lower, len(gaps)):.2g})")
    return out


def pooled_table(ra, rb, keys, la, lb):
    """The pooled table over the groups of `keys`, and a line per file whose sets were left out of a
    pooled front."""
    out = [f"| group (recordings) | {la} points dominated by {lb} | {lb} points dominated by {la} | "
           f"Pd [%] where {lb} has the lower P99 | Pd [%] where {la} has the lower P99 | share of the Pd range: "
           f"{lb} / {la} / equal | the same over the Pd both reach | {lb}'s P99 against {la}'s at equal Pd |",
           "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    left_out = defaultdict(int)
    for name, ks in groups(keys):
        (pa, oa), (pb, ob) = pooled(ra, ks), pooled(rb, ks)
        left_out[la] = max(left_out[la], oa)
        left_out[lb] = max(left_out[lb], ob)
        fa, fb = front(pa), front(pb)
        da, db, won, common = duel(fa, fb)
        (_, ta), (_, tb) = won["a"], won["b"]
        share = shares({w: won[w][0] for w in won}, "b", "a")
        out.append(f"| {name} | {da} of {len(fa)} | {db} of {len(fb)} | {tb} | {ta} | {share} | "
                   f"{shares(common, 'b', 'a')} | {percent(gap(fa, fb)[0])} |")
    for label, n in left_out.items():
        if n:
            out.append(f"\n{label}: up to {n} sets left out of a pooled front (not ok on every recording of the group)")
    return out


def only_cases(spec, studies):
    """The rows of each (path, rows) in studies whose recording is of a case named in spec (comma-separated,
    e.g. "A,B,C,D,H7"; a case, not a recording: "A" keeps A at its own seed and every other). A name with no
    recording in any file (no run of it that ran), or none at all, ends the script naming it and the cases the
    files have."""
    wanted = [c.strip() for c in spec.split(",") if c.strip()]
    have = sorted({r["key"][0] for _, rows_ in studies for r in rows_})
    unknown = [c for c in wanted if c not in have]
    if not wanted or unknown:
        what = ("names no case of" if not wanted else "is not a case of" if len(unknown) == 1 else "are not cases of")
        raise SystemExit(f"--cases: {', '.join(repr(c) for c in unknown) if wanted else repr(spec)} {what} "
                         f"{' or '.join(p for p, _ in studies)} (theirs, with runs that ran: {', '.join(have) or 'none'})")
    return [[r for r in rows_ if r["key"][0] in wanted] for _, rows_ in studies]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("a")
    ap.add_argument("b")
    ap.add_argument("--label-a", default="A")
    ap.add_argument("--label-b", default="B")
    ap.add_argument("--svg", help="also draw both fronts per case, one SVG per seed: PREFIX-own.svg, PREFIX-seed-S.svg")
    ap.add_argument("--fronts", action="store_true", help="also list the fronts' points")
    ap.add_argument("--worse-by", metavar="PARAM[,PARAM...]",
                    help="also count the runs whose case (its mean linear or angular P99) or an output (its P99) "
                         "is worse than uncompensated, per value of these parameters (empty: all runs of a file)")
    ap.add_argument("--choose-on", metavar="GROUP", action="append", default=[],
                    help="also judge the sets chosen on a group of the pooled table (its name without the count, "
                         "e.g. 'A-D, own seeds': the sets on each pooled front there) on the other recordings; "
                         "may be given more than once")
    ap.add_argument("--sample-sets", metavar="N", type=int,
                    help="compare only N sets of each file, drawn at random (a file of N sets or fewer keeps all)")
    ap.add_argument("--seed", type=int, default=1, help="the seed of --sample-sets' draw (default 1)")
    ap.add_argument("--cases", metavar="CASE[,CASE...]",
                    help="only the recordings of these cases, at every seed (e.g. A,B,C,D,H7: one run of "
                         "scripts/fronts.sh over all cases, judged as CASES=\"A B C D H7\" would)")
    args = ap.parse_args()
    sa, sb = read_study(args.a), read_study(args.b)
    la, lb = args.label_a, args.label_b
    if args.cases is not None:
        sa, sb = only_cases(args.cases, [(args.a, sa), (args.b, sb)])
    if args.sample_sets is not None:
        if args.sample_sets < 1:
            raise SystemExit(f"--sample-sets: {args.sample_sets} is not a number of sets (1 or more)")
        sampled = []
        for label, path, study in ((la, args.a, sa), (lb, args.b, sb)):
            records, total = sample_sets(study, args.sample_sets, args.seed)
            sampled.append(records)
            print(f"{label} ({path}): {min(args.sample_sets, total)} of its {total} sets"
                  + (f", drawn at random (seed {args.seed})" if args.sample_sets < total else ""))
        print()
        sa, sb = sampled
    ra, rb = rows(sa), rows(sb)
    order = lambda k: (k[1] != "own", k[1], ["A", "B", "C", "D", "S16", "H1", "H2", "H3", "H4", "H5"].index(k[0])
                       if k[0] in ["A", "B", "C", "D", "S16", "H1", "H2", "H3", "H4", "H5"] else 99, k[0])
    keys = sorted(set(ra) | set(rb), key=order)
    # The recordings both files have (a recording in one file only would empty the other's pooled front).
    both = [k for k in keys if k in ra and k in rb]
    named = {name.rsplit(" (", 1)[0]: ks for name, ks in groups(both)}
    unknown = [g for g in args.choose_on if g not in named]
    if unknown:
        raise SystemExit(f"--choose-on: no group {', '.join(repr(g) for g in unknown)} in these files "
                         f"(theirs: {', '.join(repr(n) for n in named)})")
    print("\n".join(recording_table(ra, rb, keys, la, lb)))
    print(f"\npooled: one point per set, the mean linear P99 and mean Pd over the group's recordings\n")
    print("\n".join(pooled_table(ra, rb, both, la, lb)))
    for g in args.choose_on:
        tuned = named[g]
        ca, cb = choose(ra, tuned), choose(rb, tuned)
        rest = [k for k in both if k not in tuned]
        print(f"\nchosen on {g} ({len(tuned)}): the sets on each front pooled there ({la} {len(ca)}, {lb} {len(cb)}), "
              f"judged on the other {len(rest)} recordings\n")
        if rest:
            ta, tb = only(ra, ca), only(rb, cb)
            print("\n".join(recording_table(ta, tb, rest, la, lb)))
            print()
            print("\n".join(pooled_table(ta, tb, rest, la, lb)))
    if args.worse_by is not None:
        by = [b for b in args.worse_by.split(",") if b]
        known = {p for r in sa + sb for p in r["params"]}
        unknown = [b for b in by if b not in known]
        if unknown:
            raise SystemExit(f"--worse-by: {', '.join(unknown)} is a parameter of neither {args.a} nor {args.b} "
                             f"(theirs: {', '.join(sorted(known)) or 'none'})")
        print(f"\nworse than uncompensated: the case (its mean linear or angular P99 with ALC above that without) "
              f"and per output (its P99)\n")
        print("\n".join(worse_table([(la, sa), (lb, sb)], by)))
    if args.fronts:
        print(f"\n| recording | front {la} (P99 µm / Pd %) | front {lb} (P99 µm / Pd %) |\n| --- | --- | --- |")
        show = lambda fr: " ".join(f"{p:.2f}/{d:.2f}" for p, d, _ in fr)
        for k in keys:
            print(f"| {recording_name(k)} | {show(front(ra.get(k, [])))} | {show(front(rb.get(k, [])))} |")
    if args.svg:
        for seed in sorted({k[1] for k in keys}, key=lambda s: (s != "own", s)):
            ks = [k for k in keys if k[1] == seed]
            path = f"{args.svg}-{seed.replace(' ', '-')}.svg"
            svg(path, f"Pareto fronts, mean linear P99 against Pd, {'own seeds' if seed == 'own' else seed}",
                ks, ra, rb, la, lb)


def svg(path, title, keys, ra, rb, la, lb):
    w, h, cols = 330, 270, 5
    rows_n = (len(keys) + cols - 1) // cols
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{w * cols}" height="{h * rows_n + 40}" '
           f'font-family="sans-serif" font-size="11">',
           f'<rect width="100%" height="100%" fill="white"/>',
           f'<text x="10" y="22" font-size="15">{title} ({la}: blue, {lb}: red)</text>']
    colours = {la: "#1f77b4", lb: "#d62728"}
    for n, k in enumerate(keys):
        x0, y0 = (n % cols) * w + 50, (n // cols) * h + 60
        pw, ph = w - 75, h - 90
        fa, fb = front(ra.get(k, [])), front(rb.get(k, []))
        pts = fa + fb
        if not pts:
            continue
        pd_lo, pd_hi = math.floor(min(d for _, d, _ in pts)), math.ceil(max(d for _, d, _ in pts))
        if pd_hi <= pd_lo:  # every Pd the same whole number (e.g. 100): a span of 1 % below it
            pd_lo = pd_hi - 1
        best = min(p for p, _, _ in pts)
        p_lo, p_hi = math.floor(best), math.ceil(2.5 * best)  # the fronts' interesting part
        if p_hi <= p_lo:  # a best P99 of 0 (or below): a span of 1 µm above it
            p_hi = p_lo + 1
        X = lambda pd: x0 + (pd - pd_lo) / (pd_hi - pd_lo) * pw
        Y = lambda p: y0 + ph - (p - p_lo) / (p_hi - p_lo) * ph
        out.append(f'<rect x="{x0}" y="{y0}" width="{pw}" height="{ph}" fill="none" stroke="#888"/>')
        out.append(f'<text x="{x0 + pw - 40}" y="{y0 - 6}" font-weight="bold">{k[0]}</text>')
        step = 1 if pd_hi - pd_lo <= 6 else 2
        for v in range(pd_lo, pd_hi + 1, step):
            out.append(f'<text x="{X(v) - 7:.1f}" y="{y0 + ph + 14}">{v}</text>')
        pstep = max(1, (p_hi - p_lo) // 5)
        for v in range(p_lo, p_hi + 1, pstep):
            out.append(f'<text x="{x0 - 18}" y="{Y(v) + 4:.1f}">{v}</text>')
        out.append(f'<text x="{x0 + pw / 2 - 15}" y="{y0 + ph + 28}">Pd [%]</text>')
        out.append(f'<text x="{x0 - 40}" y="{y0 - 6}">P99 [µm]</text>')
        for label, fr in ((la, fa), (lb, fb)):
            inside = [(p, d) for p, d, _ in fr if p <= p_hi]
            if inside:
                line = " ".join(f"{X(d):.1f},{Y(p):.1f}" for p, d in inside)
                out.append(f'<polyline points="{line}" fill="none" stroke="{colours[label]}" stroke-width="1.5"/>')
                for p, d in inside:
                    out.append(f'<circle cx="{X(d):.1f}" cy="{Y(p):.1f}" r="2.5" fill="{colours[label]}"/>')
    out.append("</svg>")
    with open(path, "w") as f:
        f.write("\n".join(out) + "\n")


if __name__ == "__main__":
    main()
