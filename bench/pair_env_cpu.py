#!/usr/bin/env python3
"""bench/pair_env_cpu.py: paired CPU time of any commands (one binary under different environment
variables, or several binaries on any scene).

    python3 bench/pair_env_cpu.py ROUNDS 'NAME|ENV=V ENV2=V|COMMAND' ['NAME|...|COMMAND' ...]

Each round runs every arm once, under `nice -n 5`; the arms' order is reversed every other round, so
that a load that rises or falls during a round does not always hit the same arm. The time of a run is
the CPU time (user + system) of the child from os.wait4: on a shared machine the measure that pairs
(one-thread renders: --threads 1). Prints each round, then per arm the mean, the ratio of its mean to
the first arm's, the median of the per-round ratios to the first arm and the minimum.
e.g. python3 bench/pair_env_cpu.py 4 'pass|SPECULA_TILE_PASSES=1|build/specula render m.xml --threads 1' \
         'tile||build/specula render m.xml --threads 1'
"""
import os
import shlex
import statistics
import subprocess
import sys


def main():
    rounds = int(sys.argv[1])
    arms = []
    for a in sys.argv[2:]:
        name, env, cmd = a.split("|", 2)
        e = dict(os.environ)
        for kv in env.split():
            k, v = kv.split("=", 1)
            e[k] = v
        arms.append((name, e, shlex.split(cmd)))
    t = {a[0]: [] for a in arms}
    for r in range(rounds):
        for name, e, cmd in (arms if r % 2 == 0 else arms[::-1]):
            p = subprocess.Popen(["nice", "-n", "5"] + cmd, env=e, stdout=subprocess.DEVNULL,
                                 stderr=subprocess.DEVNULL)
            _, status, ru = os.wait4(p.pid, 0)
            if status != 0:
                print("%s failed (status %d)" % (name, status))
            t[name].append(ru.ru_utime + ru.ru_stime)
        print("round", r, " ".join("%s %.3f" % (n, t[n][-1]) for n in t), flush=True)
    first = arms[0][0]
    for n in t:
        ratios = [x / y for x, y in zip(t[n], t[first])]
        print("%s mean %.3f  ratio of means %.4f  median ratio %.4f  min %.3f" % (
            n, statistics.mean(t[n]), statistics.mean(t[n]) / statistics.mean(t[first]), statistics.median(ratios),
            min(t[n])))
    os.system("uptime")
    return 0


if __name__ == "__main__":
    sys.exit(main())
