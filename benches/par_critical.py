#!/usr/bin/env python3
"""Predict the speed-up of `-j N` on N free cores from one run's
LSGEN_DEBUG_PAR=1 report (issue 15), whatever the machine's load.

usage: par_critical.py N CPU1 < stderr-of-the-j-N-run
  N     the run's -j
  CPU1  user+sys seconds of the same derivation at -j 1
  The run's own user+sys seconds go in the environment as CPUN.

Each split pass prints one line per thread (N workers, the producer, the
writer: `lsgen: par: NAME: cpu C s, waited W s ...`). On N free cores a
pass takes about the larger of its busiest thread's CPU and its total CPU
over N (the waits are not counted: on a loaded machine they mostly measure
other threads being descheduled; the report shows them). Everything
outside the split passes runs on one thread. Prints the total
CPU, the predicted wall time and the predicted speed-up CPU1 / wall.
"""
import os
import re
import sys

n = int(sys.argv[1])
cpu1 = float(sys.argv[2])
cpun = float(os.environ["CPUN"])
line_re = re.compile(r"lsgen: par: (\S+): cpu ([0-9.]+) s, waited ([0-9.]+) s")
passes, cur = [], []
for line in sys.stdin:
    m = line_re.match(line)
    if not m:
        continue
    name, cpu, waited = m.group(1), float(m.group(2)), float(m.group(3))
    cur.append((name, cpu, cpu))
    if len(cur) == n + 2:
        passes.append(cur)
        cur = []
split_cpu = sum(c for p in passes for (_, c, _) in p)
wall = cpun - split_cpu
for p in passes:
    total = sum(c for (_, c, _) in p)
    wall += max(max(cr for (_, _, cr) in p), total / n)
workers = [c for p in passes for (name, c, _) in p if name.startswith("lsgen-")]
print(f"passes {len(passes)}: split cpu {split_cpu:.3f} s (workers {sum(workers):.3f} s), "
      f"process cpu {cpun:.3f} s, -j 1 cpu {cpu1:.3f} s; predicted wall {wall:.3f} s, "
      f"speed-up {cpu1 / wall:.2f}x")
