"""scripts/build_budget.py on a made-up build: a ninja file whose steps never run and a
.ninja_log of chosen times, so the longest units, the critical path and the budget's verdict
are known in advance."""

import os
import pathlib
import subprocess
import sys
import tempfile
import unittest

SCRIPT = pathlib.Path(__file__).resolve().parents[2] / "scripts" / "build_budget.py"

NINJA = """rule cc
  command = false
build a.o: cc a.c
build b.o: cc b.c
build c.o: cc c.c
build lib.a: cc a.o b.o
build app: cc lib.a c.o
build all: phony app
"""


def log_line(start, end, out, run_started=1_000_000.0):
    # (the output's mtime in ns: when its run started plus its end, as ninja records it)
    mtime = int((run_started + end / 1000.0) * 1e9)
    return f"{start}\t{end}\t{mtime}\t{out}\t0\n"


class BuildBudget(unittest.TestCase):
    def run_script(self, steps, *args):
        with tempfile.TemporaryDirectory() as d:
            pathlib.Path(d, "build.ninja").write_text(NINJA)
            with open(os.path.join(d, ".ninja_log"), "w") as f:
                f.write("# ninja log v5\n")
                for step in steps:
                    f.write(log_line(*step))
            return subprocess.run([sys.executable, str(SCRIPT), d, *args],
                                  capture_output=True, text=True)

    # a.o 30 s and b.o 10 s in parallel, then lib.a; c.o 45 s; app after both
    STEPS = [(0, 30000, "a.o"), (0, 10000, "b.o"), (10000, 55000, "c.o"),
             (30000, 31000, "lib.a"), (55000, 57000, "app")]

    def test_critical_path_is_the_longest_chain(self):
        r = self.run_script(self.STEPS)
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
        # c.o (45) + app (2) = 47 beats a.o (30) + lib.a (1) + app (2) = 33
        self.assertIn("critical path: 47.0 s in 2 steps", r.stdout)
        self.assertIn("the last run (5 steps) took 57 s of wall time", r.stdout)
        lines = r.stdout.splitlines()
        self.assertIn("c.o", lines[1])  # the longest compile step listed first
        self.assertIn("a.o", lines[2])

    def test_a_step_over_the_budget_fails_naming_it(self):
        r = self.run_script(self.STEPS, "--budget", "40")
        self.assertEqual(r.returncode, 1)
        over = r.stdout.split("over the budget of 40 s")[1]
        self.assertIn("c.o", over)
        self.assertNotIn("a.o", over)

    def test_an_earlier_run_is_not_the_last(self):
        earlier = [(0, 5000, "a.o", 500_000.0)]
        r = self.run_script(earlier + self.STEPS[1:])
        self.assertIn("the last run (4 steps)", r.stdout)
        # a.o's time is still the latest it took
        self.assertIn("5.0 s  a.o", r.stdout)

    def test_a_folder_without_a_log_is_refused(self):
        with tempfile.TemporaryDirectory() as d:
            r = subprocess.run([sys.executable, str(SCRIPT), d], capture_output=True,
                               text=True)
        self.assertNotEqual(r.returncode, 0)
        self.assertIn(".ninja_log: no such file", r.stderr)


if __name__ == "__main__":
    unittest.main()
