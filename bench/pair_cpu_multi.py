#!/usr/bin/env python3
"""bench/pair_cpu_multi.py: paired CPU time of several specula binaries on the shared scenes.

    python3 bench/pair_cpu_multi.py ROUNDS NAME=BIN [NAME=BIN ...] [--cspp 32] [--vspp 32] [--out DIR]

bench/pair_cpu_time.sh for more than two binaries: one-thread plain path tracing of the cornell box
(256x256) and veach-mis (320x180), each render's CPU time (user + system of the child, os.wait4).
Each round renders every binary once per scene; the binaries' order rotates from round to round, so
that a load that rises or falls during a round does not always hit the same binary. Per binary and
scene: the mean and median CPU seconds, the mean's ratio to the first binary's, the median of the
per-round ratios to it and the rounds in which it was faster; then whether the last round's EXRs
are byte for byte the first binary's. Under a shared machine's load a round's times scatter by 5-15%:
a change of 1-2% needs 10 or more rounds and a check of the first binary against a copy of itself.
"""
import argparse
import os
import statistics

SCENES = os.environ.get("SCENES", "/work/shared/scenes")


def render(binary, xml, res, spp, out):
    pid = os.fork()
    if pid == 0:
        fd = os.open(os.devnull, os.O_WRONLY)
        os.dup2(fd, 1)
        os.dup2(fd, 2)
        os.execv(binary, [binary, "render", xml, "--threads", "1", "--integrator", "path", "--spp", str(spp),
                          "--res", res, "--quiet", "-o", out])
    _, status, ru = os.wait4(pid, 0)
    if status != 0:
        raise SystemExit(f"{binary} failed on {xml} (status {status})")
    return ru.ru_utime + ru.ru_stime


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("rounds", type=int)
    ap.add_argument("bins", nargs="+", help="NAME=BIN")
    ap.add_argument("--cspp", type=int, default=32)
    ap.add_argument("--vspp", type=int, default=32)
    ap.add_argument("--out", default="/tmp/pair_cpu_multi")
    a = ap.parse_args()
    bins = [b.split("=", 1) for b in a.bins]
    os.makedirs(a.out, exist_ok=True)
    scenes = [("cornell", os.path.join(SCENES, "cornell-box", "scene.xml"), "256x256", a.cspp),
              ("veach", os.path.join(SCENES, "veach-mis", "scene.xml"), "320x180", a.vspp)]
    t = {(n, s[0]): [] for n, _ in bins for s in scenes}
    for r in range(a.rounds):
        k = r % len(bins)
        for n, b in bins[k:] + bins[:k]:
            for tag, xml, res, spp in scenes:
                t[(n, tag)].append(render(b, xml, res, spp, os.path.join(a.out, f"{tag}_{n}.exr")))
        print(f"round {r + 1} " + " ".join(f"{n}:{t[(n, 'cornell')][-1]:.3f}/{t[(n, 'veach')][-1]:.3f}"
                                          for n, _ in bins), flush=True)
    first = bins[0][0]
    for tag, *_ in scenes:
        for n, _ in bins:
            x, x0 = t[(n, tag)], t[(first, tag)]
            ratios = [p / q for p, q in zip(x, x0)]
            print(f"{tag:8s} {n:10s} mean {statistics.mean(x):.3f} median {statistics.median(x):.3f}"
                  f"  vs {first}: mean {statistics.mean(x) / statistics.mean(x0):.4f}"
                  f" median ratio {statistics.median(ratios):.4f} faster {sum(q < 1 for q in ratios)}/{a.rounds}")
    for tag, *_ in scenes:
        with open(os.path.join(a.out, f"{tag}_{first}.exr"), "rb") as f:
            ref = f.read()
        for n, _ in bins[1:]:
            with open(os.path.join(a.out, f"{tag}_{n}.exr"), "rb") as f:
                same = f.read() == ref
            print(f"{tag} {n}: EXR {'identical' if same else 'DIFFERS'}")


if __name__ == "__main__":
    main()
