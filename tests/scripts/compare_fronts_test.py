#!/usr/bin/env python3
"""Tests of scripts/compare_fronts.py, the tool behind the fronts and the "never worse" counts of
docs/adaptive.md, on small study CSVs written here. Every expected value is worked out by hand in the
comment beside it, not taken from the script. Run: python3 tests/scripts/compare_fronts_test.py
(CTest: "scripts: compare_fronts")."""
import math
import os
import subprocess
import sys
import tempfile
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
SCRIPT = os.path.join(HERE, "..", "..", "scripts", "compare_fronts.py")
sys.path.insert(0, os.path.dirname(SCRIPT))
sys.dont_write_bytecode = True  # no scripts/__pycache__ in the source tree
import compare_fronts as cf  # noqa: E402

# The columns compare_fronts.py reads, in the order `alc study --csv` writes them, with two outputs.
HEADER = ("set,case,interval,move-fraction,status,error,Pd,P99_linear,P99_angular,uncompensated_P99_linear,"
          "uncompensated_P99_angular,"
          "E_X_PV,E_X_RMSE,E_X_P99,E_X_SMAPE,E_X_P99_uncompensated,E_X_measurements,"
          "E_A_PV,E_A_RMSE,E_A_P99,E_A_SMAPE,E_A_P99_uncompensated,E_A_measurements")


def row(s, case, interval, move, pd, p99, x=(1.0, 2.0), a=(3.0, 4.0), status="ok", lin_u=9, ang=(3.0, 4.0)):
    """A study row: set s on recording `case`, its mean linear P99 p99 (lin_u without compensation), its
    mean angular P99 with and without, outputs E_X and E_A as (P99 with ALC, P99 uncompensated)."""
    return (f"{s},{case},{interval},{move},{status},,{pd},{p99},{ang[0]},{lin_u},{ang[1]},"
            f"0,0,{x[0]},0,{x[1]},10,0,0,{a[0]},0,{a[1]},10")


class Files(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.TemporaryDirectory()

    def tearDown(self):
        self.dir.cleanup()

    def write(self, name, lines):
        path = os.path.join(self.dir.name, name)
        with open(path, "w") as f:
            f.write("\n".join(lines) + "\n")
        return path


class FrontTest(unittest.TestCase):
    def test_front_keeps_the_points_no_other_beats_in_both(self):
        # (P99, Pd): (2, 95) beats (3, 94) in both; (1, 90) and (2, 95) and (4, 99) trade off.
        pts = [(3.0, 94.0, "s1"), (2.0, 95.0, "s2"), (1.0, 90.0, "s3"), (4.0, 99.0, "s4"), (2.5, 95.0, "s5")]
        self.assertEqual([s for _, _, s in cf.front(pts)], ["s3", "s2", "s4"])

    def test_crossings_name_who_is_lower_along_pd(self):
        # A: 2 µm up to Pd 95; B: 1 µm up to Pd 94 and 3 µm up to 96. From 94.00 to 94.99... at Pd 94.00 B
        # has 1 < 2; above 94 B's best is 3 > 2 up to 95; above 95 only B reaches (A has no point): B.
        fa = cf.front([(2.0, 95.0, "a")])
        fb = cf.front([(1.0, 94.0, "b1"), (3.0, 96.0, "b2")])
        spans = [(round(lo, 2), round(hi, 2), w) for lo, hi, w in cf.crossings(fa, fb)]
        self.assertEqual(spans, [(94.0, 94.0, "b"), (94.01, 95.0, "a"), (95.01, 96.0, "b")])

    def test_the_shares_over_the_pd_both_fronts_reach(self):
        # A: 1 µm at Pd 90, 2 µm at 96; B: 1.5 µm at 94, 3 µm at 97. Along Pd 90.00-97.00: at 90.00 A (1 <
        # 1.5); 90.01-94.00 B (A's best above 90 is 2); 94.01-96.00 A (2 < 3); 96.01-97.00 B (A has no
        # point). Widths: A 0.01 + 2.00 = 2.01, B 4.00 + 1.00 = 5.00. Both reach from Pd 94 (B's lowest):
        # A 2.00, B 0.01 (94.00) + 1.00 = 1.01; shares of 3.01: B 33.6 %, A 66.4 %, equal 0.
        fa = cf.front([(1.0, 90.0, "a1"), (2.0, 96.0, "a2")])
        fb = cf.front([(1.5, 94.0, "b1"), (3.0, 97.0, "b2")])
        _, _, won, common = cf.duel(fa, fb)
        self.assertEqual({w: round(won[w][0], 2) for w in won}, {"a": 2.01, "b": 5.0, "=": 0.0})
        self.assertEqual({w: round(common[w], 2) for w in common}, {"a": 2.0, "b": 1.01, "=": 0.0})
        self.assertEqual(cf.shares(common, "b", "a"), "33.6 / 66.4 / 0.0 %")
        self.assertEqual(cf.shares({"a": 0.0, "b": 0.0, "=": 0.0}, "b", "a"), "—")

    def test_the_p99_at_equal_pd_over_the_pd_both_reach(self):
        # The fronts of the shares' test. Both reach Pd 94 (B's lowest) to 96 (A's highest): 201 steps.
        # At 94.00 B 1.5 against A 2 (-25 %); at 94.01-96.00 (200 steps) B 3 against A 2 (+50 %): the mean
        # (-25 + 200 x 50) / 201 = 49.6269 %.
        fa = cf.front([(1.0, 90.0, "a1"), (2.0, 96.0, "a2")])
        fb = cf.front([(1.5, 94.0, "b1"), (3.0, 97.0, "b2")])
        g, steps = cf.gap(fa, fb)
        self.assertEqual(steps, 201)
        self.assertAlmostEqual(g, 9975.0 / 201, places=9)
        # The other way round: A against B, -33.3 % at 94.01-96.00 and +33.3 % at 94.00.
        self.assertAlmostEqual(cf.gap(fb, fa)[0], (100 / 3 - 200 * 100 / 3) / 201, places=9)
        # Ranges that do not meet (A up to Pd 90, B from 95), or a front without points: no figure.
        g, steps = cf.gap(cf.front([(1.0, 90.0, "a")]), cf.front([(2.0, 95.0, "b")]))
        self.assertTrue(math.isnan(g))
        self.assertEqual(steps, 0)
        self.assertEqual(cf.gap([], fb)[1], 0)
        self.assertEqual(cf.percent(-25.0), "-25.0 %")
        self.assertEqual(cf.percent(math.nan), "—")

    def test_the_sign_test_of_the_split(self):
        # 9 of 12: 2 x (1 + 12 + 66 + 220) / 4096 = 0.14599...; 0 of 5 (or 5 of 5): 2 / 32; 5 of 10: 1.
        self.assertAlmostEqual(cf.sign_test(9, 12), 598 / 4096, places=12)
        self.assertAlmostEqual(cf.sign_test(3, 12), 598 / 4096, places=12)
        self.assertAlmostEqual(cf.sign_test(0, 5), 2 / 32, places=12)
        self.assertAlmostEqual(cf.sign_test(5, 5), 2 / 32, places=12)
        self.assertEqual(cf.sign_test(5, 10), 1.0)
        self.assertTrue(math.isnan(cf.sign_test(0, 0)))

    def test_pooled_means_the_sets_that_ran_on_every_recording(self):
        by_case = {("A", "own"): [(1.0, 90.0, "s1"), (2.0, 96.0, "s2")], ("B", "own"): [(3.0, 94.0, "s1")]}
        points, left_out = cf.pooled(by_case, [("A", "own"), ("B", "own")])
        self.assertEqual(points, [(2.0, 92.0, "s1")])  # (1 + 3) / 2, (90 + 94) / 2; s2 is not on B
        self.assertEqual(left_out, 1)

    def test_the_sets_chosen_are_those_of_the_front_pooled_over_the_group(self):
        # Pooled over A and B: s1 (1.5, 92), s2 (2.5, 91) which s1 beats in both, s3 (2.5, 95); s4 ran on A
        # only. The pooled front: s1 and s3. On A alone s2 (1.0, 90) would be on A's front, but it is not
        # chosen: a user who tunes on the group sets one set for all of it.
        by_case = {("A", "own"): [(1.0, 90.0, "s1"), (1.0, 90.0, "s2"), (2.0, 96.0, "s3"), (0.5, 99.0, "s4")],
                   ("B", "own"): [(2.0, 94.0, "s1"), (4.0, 92.0, "s2"), (3.0, 94.0, "s3")]}
        self.assertEqual(cf.choose(by_case, [("A", "own"), ("B", "own")]), {"s1", "s3"})
        self.assertEqual(cf.only(by_case, {"s3"}), {("A", "own"): [(2.0, 96.0, "s3")], ("B", "own"): [(3.0, 94.0, "s3")]})

    def test_a_sample_of_sets_keeps_whole_sets_and_repeats_with_its_seed(self):
        # 5 sets on two recordings each: a sample of 2 keeps both rows of each set drawn, the same seed draws
        # the same sets, and a file of no more sets than asked keeps all of them.
        records = [{"key": (c, "own"), "set": f"s{i}"} for i in range(5) for c in ("A", "B")]
        kept, total = cf.sample_sets(records, 2, 7)
        self.assertEqual(total, 5)
        names = {r["set"] for r in kept}
        self.assertEqual(len(names), 2)
        self.assertEqual(len(kept), 4)
        self.assertEqual(kept, cf.sample_sets(records, 2, 7)[0])
        draws = {frozenset(r["set"] for r in cf.sample_sets(records, 2, seed)[0]) for seed in range(20)}
        self.assertGreater(len(draws), 1)  # the seed is used: 10 possible pairs, 20 seeds
        self.assertEqual(cf.sample_sets(records, 5, 7), (records, 5))


class ReadTest(Files):
    def test_rows_and_outputs_are_read_with_their_names(self):
        path = self.write("p.csv", [HEADER, row(1, "A", 2, 0.5, 95.5, 1.25, x=(2.5, 2.0)),
                                    row(2, "A", 2, 0.5, 96, 9, status="error")])
        records = cf.read_study(path)
        self.assertEqual(len(records), 1)  # the error row is no point
        r = records[0]
        self.assertEqual(r["key"], ("A", "own"))
        self.assertEqual(r["set"], "interval=2 move-fraction=0.5")
        self.assertEqual((r["P99"], r["Pd"]), (1.25, 95.5))
        self.assertEqual(r["outputs"], [("E_X", 2.5, 2.0), ("E_A", 3.0, 4.0)])
        self.assertEqual(cf.worse(r), ["E_X"])

    def test_a_row_of_another_recording_is_named_by_position(self):
        # A recording with one output joined under a header of two (fronts.sh joins under the first).
        one = "1,S16 seed 2.csv,2,0.5,ok,,95,2,,9,,0,0,7,0,6,10"
        r = cf.read_study(self.write("p.csv", [HEADER, one]))[0]
        self.assertEqual(r["key"], ("S16", "seed 2"))
        self.assertEqual(r["outputs"], [("output 1", 7.0, 6.0)])
        # No angular output: its means are empty, no number to be worse with; the linear 2 < 9 is not worse.
        self.assertFalse(cf.case_worse(r))
        self.assertEqual(cf.worse(r), ["output 1"])

    def test_an_output_the_recording_does_not_have_is_no_output(self):
        # A study over recordings with other outputs writes every output of any in each row: E_X's six
        # cells empty here, so the row has one output (E_A), not two.
        r = cf.read_study(self.write("p.csv", [HEADER, row(1, "A", 2, 0.5, 95, 1).replace(",0,0,1.0,0,2.0,10,", ",,,,,,,")]))[0]
        self.assertEqual(r["outputs"], [("E_A", 3.0, 4.0)])
        self.assertEqual(cf.worse_table([("paper", [r])], [])[2:], ["| paper | all | 1 | 0 | 0 | 0 / 1 | — |"])

    def test_an_empty_output_p99_is_not_worse(self):
        # E_X not measured (empty P99 with ALC), E_A's uncompensated P99 empty: neither is worse, nor 0.
        r = cf.read_study(self.write("p.csv", [HEADER, row(1, "A", 2, 0.5, 95, 1, x=("", 2.0), a=(3.0, ""))]))[0]
        self.assertEqual([o[0] for o in r["outputs"]], ["E_X", "E_A"])
        self.assertNotEqual(r["outputs"][0][1], 0.0)
        self.assertEqual(cf.worse(r), [])

    def test_a_row_cut_short_names_the_file_and_line(self):
        path = self.write("cut.csv", [HEADER, row(1, "A", 2, 0.5, 95, 1), "2,A,3,0.5,ok,,95,1,3,9,4,0,0"])
        with self.assertRaises(SystemExit) as e:
            cf.read_study(path)
        self.assertIn("cut.csv:3: 13 fields, where a row holds 11 and 6 per output", str(e.exception))

    def test_an_output_p99_that_is_no_number_names_the_file_and_line(self):
        bad = row(1, "A", 2, 0.5, 95, 1).replace(",0,0,1.0,0,2.0,", ",0,0,x1,0,2.0,")
        with self.assertRaises(SystemExit) as e:
            cf.read_study(self.write("bad.csv", [HEADER, bad]))
        self.assertIn("bad.csv:2: the P99 of E_X 'x1' is not a number", str(e.exception))
        # A case mean is read as strictly: only an empty cell is no number.
        bad = row(1, "A", 2, 0.5, 95, 1, lin_u="n/a")
        with self.assertRaises(SystemExit) as e:
            cf.read_study(self.write("bad2.csv", [HEADER, bad]))
        self.assertIn("bad2.csv:2: uncompensated_P99_linear 'n/a' is not a number", str(e.exception))

    def test_a_file_without_the_columns_is_refused(self):
        with self.assertRaises(SystemExit) as e:
            cf.read_study(self.write("x.csv", ["set,case,status,Pd", "1,A,ok,95"]))
        self.assertIn("x.csv:1: not a study CSV", str(e.exception))
        self.assertIn("P99_linear", str(e.exception))


class WorseTest(Files):
    def test_worse_counts_per_parameter_value(self):
        paper = cf.read_study(self.write("p.csv", [
            HEADER,
            row(1, "A", 2, 0.5, 95, 1, x=(2.0, 2.0)),   # equal is not worse
            row(2, "A", 2, "inf", 95, 1, x=(2.1, 2.0), a=(5.0, 4.0)),  # two outputs worse, the case not
            row(3, "B", 2, "inf", 95, 9.5),               # no output, but the case's linear P99 9.5 > 9
            row(4, "B", "inf", "", 99, 5, a=(4.5, 4.0), ang=(4.5, 4.0)),  # move fraction moot: one worse, angular too
        ]))
        lines = cf.worse_table([("paper", paper)], ["move-fraction"])
        self.assertEqual(lines[2:], [
            "| paper | 0.5 | 1 | 0 | 0 | 0 / 2 | — |",
            "| paper | inf | 2 | 1 | 1 | 2 / 4 | A (1) |",
            "| paper | (moot) | 1 | 1 | 1 | 1 / 2 | B (1) |",
        ])
        # Without a parameter: one line per file.
        self.assertEqual(cf.worse_table([("paper", paper)], [])[2:],
                         ["| paper | all | 4 | 2 | 2 | 3 / 8 | A (1), B (1) |"])

    def test_values_in_numeric_order_then_moot_and_recordings_by_name(self):
        # Written out of order: a string sort would put 10 before 2; recordings listed B before A.
        paper = cf.read_study(self.write("p.csv", [
            HEADER,
            row(1, "B", "", 0.5, 95, 1),
            row(2, "B", "inf", 0.5, 95, 1),
            row(3, "B", 10, 0.5, 95, 1, x=(3.0, 2.0)),
            row(4, "A", 10, 0.5, 95, 1, x=(3.0, 2.0)),
            row(5, "B", 2, 0.5, 95, 9, ang=(4.0, 4.0)),  # case means equal to uncompensated: not worse
        ]))
        lines = cf.worse_table([("paper", paper)], ["interval"])
        self.assertEqual(lines[2:], [
            "| paper | 2 | 1 | 0 | 0 | 0 / 2 | — |",
            "| paper | 10 | 2 | 0 | 2 | 2 / 4 | A (1), B (1) |",
            "| paper | inf | 1 | 0 | 0 | 0 / 2 | — |",
            "| paper | (moot) | 1 | 0 | 0 | 0 / 2 | — |",
        ])

    def test_the_command_prints_the_table_after_the_fronts(self):
        a = self.write("a.csv", [HEADER, row(1, "A", 2, 0.5, 95, 2.0), row(2, "A", 2, "inf", 96, 3.0, x=(3, 2))])
        b = self.write("b.csv", [HEADER, row(1, "A", 2, 0.5, 95, 1.5)])
        out = subprocess.run([sys.executable, SCRIPT, a, b, "--label-a", "paper", "--label-b", "adaptive",
                              "--worse-by", "move-fraction"], capture_output=True, text=True, check=True).stdout
        self.assertIn("| A | 1 of 2 | 0 of 1 |", out)  # adaptive's (1.5, 95) dominates paper's (2, 95) only
        # Both reach Pd 95 only (adaptive's highest; above it only paper reaches and wins): 1.5 against 2, -25 %.
        self.assertIn("| 95.00 | 95.01–96.00 | -25.0 % |", out)
        self.assertIn("adaptive's P99 against paper's at equal Pd (over the Pd both reach): mean -25.0 %, median "
                      "-25.0 % over 1 recordings, lower on average on 1 of them, paper's on 0 (sign test, two-sided: "
                      "p = 1)", out)
        tail = out[out.index("worse than uncompensated: the case"):].splitlines()
        self.assertIn("| paper | inf | 1 | 0 | 1 | 1 / 2 | A (1) |", tail)
        self.assertIn("| adaptive | 0.5 | 1 | 0 | 0 | 0 / 2 | — |", tail)
        # A parameter neither file has is refused, naming theirs.
        bad = subprocess.run([sys.executable, SCRIPT, a, b, "--worse-by", "move_fraction"], capture_output=True,
                             text=True)
        self.assertNotEqual(bad.returncode, 0)
        self.assertIn("--worse-by: move_fraction is a parameter of neither", bad.stderr)
        self.assertIn("(theirs: interval, move-fraction)", bad.stderr)
        # Without --worse-by there is no such table.
        plain = subprocess.run([sys.executable, SCRIPT, a, b], capture_output=True, text=True, check=True).stdout
        self.assertNotIn("worse than uncompensated", plain)

    def test_the_sets_chosen_on_one_group_are_judged_on_the_others(self):
        # Paper: p1 (Pd 90, 2 µm) beats p2 (90, 3) on A and B at their own seeds, so p1 is chosen; at seed 2 p2
        # is the better (1 against 2.5), but it was not chosen. Adaptive: q1 (90, 1.8) beats q2 (90, 2.2) at the
        # own seeds; at seed 2 q1 2.0, q2 0.5. Judged at seed 2 with the chosen sets: q1 2.0 against p1 2.5,
        # -20 % on both recordings (in hindsight it would be q2 0.5 against p2 1.0, -50 %).
        lines_a, lines_b = [HEADER], [HEADER]
        for case, (p1, p2, q1, q2) in {"A": (2, 3, 1.8, 2.2), "B": (2, 3, 1.8, 2.2),
                                       "A seed 2": (2.5, 1.0, 2.0, 0.5), "B seed 2": (2.5, 1.0, 2.0, 0.5)}.items():
            lines_a += [row(1, case, 1, 0.5, 90, p1), row(2, case, 2, 0.5, 90, p2)]
            lines_b += [row(1, case, 1, 0.5, 90, q1), row(2, case, 2, 0.5, 90, q2)]
        a, b = self.write("a.csv", lines_a), self.write("b.csv", lines_b)
        out = subprocess.run([sys.executable, SCRIPT, a, b, "--label-a", "paper", "--label-b", "adaptive",
                              "--choose-on", "A-D, own seeds"], capture_output=True, text=True, check=True).stdout
        self.assertIn("| A seed 2 | 1 of 1 | 0 of 1 | 0.00 | 0.00 | 90.00 | — | -50.0 % |", out)  # in hindsight
        chosen = out[out.index("chosen on A-D, own seeds (2)"):]
        self.assertIn("the sets on each front pooled there (paper 1, adaptive 1), judged on the other 2 recordings",
                      chosen)
        self.assertIn("| A seed 2 | 1 of 1 | 0 of 1 | 0.00 | 0.00 | 90.00 | — | -20.0 % |", chosen)
        self.assertIn("| B seed 2 | 1 of 1 | 0 of 1 | 0.00 | 0.00 | 90.00 | — | -20.0 % |", chosen)
        self.assertNotIn("| A |", chosen)  # the recordings it was chosen on are not judged again
        self.assertIn("mean -20.0 %, median -20.0 % over 2 recordings, lower on average on 2 of them, paper's on 0 "
                      "(sign test, two-sided: p = 0.5)", chosen)
        self.assertIn("| A-D, seed 2 (2) | 1 of 1 | 0 of 1 | 90.00 | — | 100.0 / 0.0 / 0.0 % | 100.0 / 0.0 / 0.0 % | "
                      "-20.0 % |", chosen)
        # A group the files do not have is refused, naming theirs; so is a sample of no sets.
        bad = subprocess.run([sys.executable, SCRIPT, a, b, "--choose-on", "A-D"], capture_output=True, text=True)
        self.assertNotEqual(bad.returncode, 0)
        self.assertIn("--choose-on: no group 'A-D' in these files (theirs: 'A-D, own seeds', 'A-D, seed 2', "
                      "'A-D, all seeds'", bad.stderr)
        bad = subprocess.run([sys.executable, SCRIPT, a, b, "--sample-sets", "0"], capture_output=True, text=True)
        self.assertNotEqual(bad.returncode, 0)
        self.assertIn("--sample-sets: 0 is not a number of sets", bad.stderr)
        # A sample as large as both grids keeps every set and says so; the tables are those without it.
        same = subprocess.run([sys.executable, SCRIPT, a, b, "--sample-sets", "2"], capture_output=True, text=True,
                              check=True).stdout
        self.assertTrue(same.startswith(f"A ({a}): 2 of its 2 sets\nB ({b}): 2 of its 2 sets\n\n"))
        plain = subprocess.run([sys.executable, SCRIPT, a, b], capture_output=True, text=True, check=True).stdout
        self.assertEqual(same[same.index("| recording"):], plain)

    def test_only_the_recordings_of_the_cases_named(self):
        # A and B at their own seeds and at seed 2, H7 at its own seed. With --cases A,H7 the tables hold A, A seed
        # 2 and H7, not B; the pooled A-D groups have A's recordings alone: at seed 2 p1 (90, 2.5) against q1
        # (90, 2.0), -20 %, where with B (p 3.5, q 3.5: 0 %) they would pool to 3.0 against 2.75, -8.3 %.
        lines_a, lines_b = [HEADER], [HEADER]
        for case, (p1, q1) in {"A": (2, 1.8), "B": (3, 3), "A seed 2": (2.5, 2.0), "B seed 2": (3.5, 3.5),
                               "H7": (4, 5)}.items():
            lines_a.append(row(1, case, 1, 0.5, 90, p1))
            lines_b.append(row(1, case, 1, 0.5, 90, q1))
        a, b = self.write("a.csv", lines_a), self.write("b.csv", lines_b)
        run = lambda *extra: subprocess.run([sys.executable, SCRIPT, a, b, "--label-a", "paper", "--label-b", "adaptive",
                                             *extra], capture_output=True, text=True)
        out = run("--cases", "A,H7", "--worse-by", "").stdout
        self.assertIn("| A | 1 of 1 | 0 of 1 | 0.00 | 0.00 | 90.00 | — | -10.0 % |", out)  # 1.8 against 2
        self.assertIn("| A seed 2 | 1 of 1 | 0 of 1 | 0.00 | 0.00 | 90.00 | — | -20.0 % |", out)
        self.assertIn("| H7 | 0 of 1 | 1 of 1 | 0.00 | 0.00 | — | 90.00 | +25.0 % |", out)
        self.assertNotIn("| B |", out)
        self.assertNotIn("| B seed 2 |", out)
        self.assertIn("| A-D, seed 2 (1) | 1 of 1 | 0 of 1 | 90.00 | — | 100.0 / 0.0 / 0.0 % | 100.0 / 0.0 / 0.0 % | "
                      "-20.0 % |", out)
        # The worse-than-uncompensated counts too: 3 runs per file (A, A seed 2, H7), not 5; every row has E_X at
        # 1 against 2 and E_A at 3 against 4, so none is worse.
        self.assertIn("| paper | all | 3 | 0 | 0 | 0 / 6 | — |", out)
        self.assertIn("| adaptive | all | 3 | 0 | 0 | 0 / 6 | — |", out)
        everything = run().stdout
        self.assertIn("| A-D, seed 2 (2) |", everything)
        self.assertIn("| B seed 2 |", everything)
        # A case the files do not have is refused, naming it and theirs; so is a list of no case.
        bad = run("--cases", "A,H8")
        self.assertNotEqual(bad.returncode, 0)
        self.assertIn(f"--cases: 'H8' is not a case of {a} or {b} (theirs, with runs that ran: A, B, H7)", bad.stderr)
        bad = run("--cases", "H8,H9")
        self.assertIn(f"--cases: 'H8', 'H9' are not cases of {a} or {b}", bad.stderr)
        bad = run("--cases", ",")
        self.assertNotEqual(bad.returncode, 0)
        self.assertIn(f"--cases: ',' names no case of {a} or {b} (theirs, with runs that ran: A, B, H7)", bad.stderr)


if __name__ == "__main__":
    unittest.main(verbosity=2)
