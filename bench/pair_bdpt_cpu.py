#!/usr/bin/env python3
# python3 bench/pair_bdpt_cpu.py ROUNDS SPP RES: needs /tmp/bdpt28b/specula_base and specula_new (edit BINS); prints
# per scene the mean CPU seconds, the mean ratio, the median per-round ratio and whether the EXRs are byte-identical.
# paired one-thread CPU time of bdpt, base vs new, alternating order per round
import os, sys, statistics
ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
SC = {"caustic_sphere": "scenes/caustic_sphere.xml", "indirect_door": "scenes/indirect_door.xml",
      "indirect_lamp_glass": "scenes/indirect_lamp_glass.xml"}
BINS = {"base": "/tmp/bdpt28b/specula_base", "new": "/tmp/bdpt28b/specula_new"}
rounds = int(sys.argv[1]); spp = sys.argv[2]; res = sys.argv[3]
def run(b, xml, out):
    pid = os.fork()
    if pid == 0:
        fd = os.open(os.devnull, os.O_WRONLY); os.dup2(fd, 1); os.dup2(fd, 2)
        os.execv(b, [b, "render", os.path.join(ROOT, xml), "--integrator", "bdpt", "--threads", "1", "--spp", spp,
                     "--seed", "7", "--quiet", "-o", out, "-D", f"res={res}"])
    _, st, ru = os.wait4(pid, 0)
    assert st == 0, st
    return ru.ru_utime + ru.ru_stime
t = {(n, s): [] for n in BINS for s in SC}
for r in range(rounds):
    order = list(BINS) if r % 2 == 0 else list(BINS)[::-1]
    for s, xml in SC.items():
        for n in order:
            t[(n, s)].append(run(BINS[n], xml, f"/tmp/bdpt28b/{s}_{n}.exr"))
for s in SC:
    b, c = t[("base", s)], t[("new", s)]
    ratios = [x / y for x, y in zip(c, b)]
    print(f"{s}: base mean {statistics.mean(b):.3f}s new {statistics.mean(c):.3f}s ratio(mean) {statistics.mean(c)/statistics.mean(b):.4f} "
          f"median per-round ratio {statistics.median(ratios):.4f} new faster in {sum(x < 1 for x in ratios)}/{rounds}")
    same = open(f"/tmp/bdpt28b/{s}_base.exr", "rb").read() == open(f"/tmp/bdpt28b/{s}_new.exr", "rb").read()
    print(f"  EXR byte-identical: {same}")
