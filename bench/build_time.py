#!/usr/bin/env python3
"""How long a from-scratch build takes on N idle cores, measured on a machine other jobs share.

The wall time of a build on a busy machine says little; the CPU time of each of its steps does not depend much on the
load. This script replays the steps of one ninja build through a list schedule on N workers (a worker starts the next
ready step as soon as it is free, in the order ninja started them), so the wall time of an idle N-core machine comes
out of step durations measured anywhere.

  # 1. a fresh build folder whose every step records its CPU time (user + sys of all it runs, bench/edge_cpu.sh)
  cmake -S . -B out/fresh -G Ninja
  python3 bench/build_time.py wrap out/fresh
  time ninja -C out/fresh                      # CPU time in all: user + sys of this line
  # 2. the estimate: 2 workers, step durations = recorded CPU seconds x SCALE
  python3 bench/build_time.py estimate out/fresh --cpu out/fresh/edge_cpu.tsv --scale 1.0

Without --cpu the durations are the wall times in .ninja_log, so a log recorded on an idle machine replays itself:
`estimate /tmp/fresh` must give back that build's own wall time (the check that the graph and the schedule are right).
`calibrate` compares the steps two builds share: the median of (duration in an idle build's .ninja_log) / (recorded CPU
seconds) is the SCALE that turns CPU seconds into idle wall seconds on that machine (process start, I/O, the kernel).

The dependency graph comes from the folder's build.ninja (explicit, implicit and order-only inputs); phony steps take no
time and no worker. `wrap` rewrites CMakeFiles/rules.ninja of a freshly configured folder (configure again to undo).
"""
import argparse
import os
import shlex
import statistics
import sys

HERE = os.path.dirname(os.path.abspath(__file__))


def read_manifest_lines(path):
    """build.ninja's logical lines ('$' at the end of a line continues it)."""
    lines, cur = [], ""
    with open(path) as f:
        for raw in f:
            raw = raw.rstrip("\n")
            piece = raw.lstrip() if cur else raw
            if (len(raw) - len(raw.rstrip("$"))) % 2 == 1:
                cur += piece[:-1]
                continue
            cur += piece
            lines.append(cur)
            cur = ""
    if cur:
        lines.append(cur)
    return lines


def split_paths(text):
    """Ninja's path list: separated by unescaped spaces; '$ ', '$:' and '$$' are escapes."""
    out, cur, i = [], "", 0
    while i < len(text):
        c = text[i]
        if c == "$" and i + 1 < len(text):
            cur += text[i + 1]
            i += 2
            continue
        if c == " ":
            if cur:
                out.append(cur)
            cur = ""
        else:
            cur += c
        i += 1
    if cur:
        out.append(cur)
    return out


def find_colon(text):
    i = 0
    while i < len(text):
        if text[i] == "$":
            i += 2
            continue
        if text[i] == ":":
            return i
        i += 1
    raise ValueError("build line without ':': " + text)


def parse_build_ninja(build_dir):
    """Edges as (outputs, rule, inputs), and the default targets (CMake's `default all`)."""
    edges, defaults = [], []
    for line in read_manifest_lines(os.path.join(build_dir, "build.ninja")):
        if line.startswith("default "):
            defaults += split_paths(line[len("default "):])
        if not line.startswith("build "):
            continue
        body = line[len("build "):]
        colon = find_colon(body)
        outs = split_paths(body[:colon].replace(" | ", " "))
        rest = split_paths(body[colon + 1:])
        rule, inputs = rest[0], [p for p in rest[1:] if p not in ("|", "||", "|@")]
        edges.append((outs, rule, inputs))
    return edges, defaults


def read_ninja_log(path):
    """Output -> (start, end) in seconds, the latest entry of each output. `path`: a .ninja_log or its build folder."""
    if os.path.isdir(path):
        path = os.path.join(path, ".ninja_log")
    entries = {}
    with open(path) as f:
        header = f.readline()
        if not header.startswith("# ninja log v5"):
            sys.exit(f"{path}: not a ninja log v5 ({header.strip()}); use ninja 1.10 or 1.11")
        for line in f:
            start, end, _, out, _ = line.rstrip("\n").split("\t")
            entries[out] = (int(start) / 1000.0, int(end) / 1000.0)
    return entries


def read_cpu(path):
    cpu = {}
    with open(path) as f:
        for line in f:
            secs, out = line.rstrip("\n").split("\t")
            cpu[out] = cpu.get(out, 0.0) + float(secs)
    return cpu


class Build:
    def __init__(self, build_dir, cpu=None, scale=1.0, log_path=None):
        self.edges, defaults = parse_build_ninja(build_dir)
        log = read_ninja_log(log_path or build_dir)
        producer = {}
        for i, (outs, _, _) in enumerate(self.edges):
            for o in outs:
                producer[o] = i
        deps = [sorted({producer[p] for p in ins if p in producer}) for _, _, ins in self.edges]
        # Only what the default target needs (a plain `ninja`): not install, edit_cache, ...
        wanted, stack = set(), [producer[t] for t in defaults if t in producer]
        while stack:
            i = stack.pop()
            if i not in wanted:
                wanted.add(i)
                stack.extend(deps[i])
        keep = sorted(wanted) if defaults else list(range(len(self.edges)))
        index = {old: new for new, old in enumerate(keep)}
        self.edges = [self.edges[i] for i in keep]
        self.deps = [[index[d] for d in deps[i]] for i in keep]
        self.duration, self.start, self.source = [], [], []
        for outs, rule, _ in self.edges:
            logged = [log[o] for o in outs if o in log]
            measured = [cpu[o] for o in outs if cpu and o in cpu]
            if rule == "phony" or (not logged and not measured):
                self.duration.append(0.0)
                self.source.append("none" if rule == "phony" else "missing")
            elif measured:
                self.duration.append(max(measured) * scale)
                self.source.append("cpu")
            else:
                self.duration.append(max(e - s for s, e in logged))
                self.source.append("log")
            self.start.append(min((s for s, _ in logged), default=float("inf")))
        self.logged_wall = max((e for _, e in log.values()), default=0.0)

    def name(self, i):
        return self.edges[i][0][0]

    def tail(self):
        """Longest path from each edge to the end of the build (its own duration included)."""
        memo = [None] * len(self.edges)
        users = [[] for _ in self.edges]
        for i, ds in enumerate(self.deps):
            for d in ds:
                users[d].append(i)
        order = self.topological()
        for i in reversed(order):
            memo[i] = self.duration[i] + max((memo[u] for u in users[i]), default=0.0)
        return memo

    def topological(self):
        indeg = [len(ds) for ds in self.deps]
        users = [[] for _ in self.edges]
        for i, ds in enumerate(self.deps):
            for d in ds:
                users[d].append(i)
        stack = [i for i, n in enumerate(indeg) if n == 0]
        order = []
        while stack:
            i = stack.pop()
            order.append(i)
            for u in users[i]:
                indeg[u] -= 1
                if indeg[u] == 0:
                    stack.append(u)
        if len(order) != len(self.edges):
            sys.exit("build.ninja has a cycle")
        return order

    def schedule(self, workers, priority):
        """List schedule: returns (wall, per-edge (start, end))."""
        import heapq
        n = len(self.edges)
        waiting = [len(ds) for ds in self.deps]
        users = [[] for _ in range(n)]
        for i, ds in enumerate(self.deps):
            for d in ds:
                users[d].append(i)
        ready = []  # heap of (priority, edge)
        running = []  # heap of (end, edge)
        times = [None] * n
        now = 0.0

        def finish(i, t):
            times[i] = (times[i][0], t)
            for u in users[i]:
                waiting[u] -= 1
                if waiting[u] == 0:
                    release(u, t)

        def release(i, t):
            if self.duration[i] == 0.0:
                times[i] = (t, t)
                finish(i, t)
            else:
                heapq.heappush(ready, (priority[i], i))

        for i in [i for i in range(n) if waiting[i] == 0]:
            release(i, 0.0)
        while ready or running:
            while ready and len(running) < workers:
                _, i = heapq.heappop(ready)
                times[i] = (now, None)
                heapq.heappush(running, (now + self.duration[i], i))
            end, i = heapq.heappop(running)
            now = end
            finish(i, end)
        return now, times


def fmt(secs):
    return f"{int(secs // 60)} min {secs % 60:04.1f} s ({secs:.0f} s)"


def cmd_estimate(args):
    cpu = read_cpu(args.cpu) if args.cpu else None
    b = Build(args.build_dir, cpu, args.scale, args.log)
    missing = [b.name(i) for i, src in enumerate(b.source) if src == "missing"]
    if missing:
        print(f"{len(missing)} steps neither in the log nor measured, counted as 0 s: {' '.join(missing[:12])}"
              f"{' ...' if len(missing) > 12 else ''}")
    total = sum(b.duration)
    by_source = {}
    for d, s in zip(b.duration, b.source):
        by_source[s] = by_source.get(s, 0.0) + d
    print(f"steps: {sum(1 for d in b.duration if d > 0)} timed "
          f"({', '.join(f'{k}: {v:.0f} s' for k, v in sorted(by_source.items()) if k != 'none')})")
    print(f"sum of step durations: {fmt(total)}; logged wall of that build: {fmt(b.logged_wall)}")
    tails = b.tail()
    crit = max(tails)
    print(f"lower bounds on {args.workers} workers: sum/{args.workers} = {fmt(total / args.workers)}, "
          f"longest path = {fmt(crit)}")
    ninja_order = [(b.start[i], i) for i in range(len(b.edges))]
    wall, times = b.schedule(args.workers, ninja_order)
    print(f"estimate, {args.workers} workers, ninja's start order: {fmt(wall)}")
    wall_cp, _ = b.schedule(args.workers, [(-t, i) for i, t in enumerate(tails)])
    print(f"estimate, {args.workers} workers, longest path first:  {fmt(wall_cp)}")
    # The critical path: from the first step, follow the dependency that finished last.
    last = max(range(len(b.edges)), key=lambda i: times[i][1])
    path = []
    i = last
    while i is not None:
        if b.duration[i] > 0:
            path.append(i)
        ds = [d for d in b.deps[i]]
        i = max(ds, key=lambda d: times[d][1]) if ds else None
    print(f"chain ending the schedule ({len(path)} steps, {sum(b.duration[j] for j in path):.0f} s of work):")
    for j in reversed(path):
        print(f"  {times[j][0]:7.1f} +{b.duration[j]:6.1f} s  {b.name(j)}")
    if args.top:
        print(f"largest {args.top} steps:")
        for j in sorted(range(len(b.edges)), key=lambda j: -b.duration[j])[:args.top]:
            print(f"  {b.duration[j]:6.1f} s  {b.name(j)}")


def cmd_calibrate(args):
    idle = read_ninja_log(args.idle_dir)
    cpu = read_cpu(args.cpu)
    ratios = []
    for out, secs in cpu.items():
        if out in idle and secs >= args.min_seconds:
            s, e = idle[out]
            ratios.append(((e - s) / secs, out, e - s, secs))
    if not ratios:
        sys.exit("no step longer than --min-seconds in both builds")
    ratios.sort()
    q = statistics.quantiles([r for r, *_ in ratios], n=4)
    print(f"{len(ratios)} shared steps of >= {args.min_seconds} s CPU: idle wall / CPU median "
          f"{statistics.median(r for r, *_ in ratios):.3f} (quartiles {q[0]:.3f}, {q[2]:.3f})")
    if args.verbose:
        for r, out, w, c in ratios:
            print(f"  {r:6.3f}  {w:6.1f} s / {c:6.1f} s  {out}")


def cmd_measure(args):
    """Runs the commands that build the given outputs again, without ccache, each under edge_cpu.sh."""
    import subprocess
    log = os.path.abspath(args.cpu)
    recorder = os.path.join(HERE, "edge_cpu.sh")
    env = dict(os.environ, CCACHE_DISABLE="1")
    for out in args.outputs:
        cmd = subprocess.run(["ninja", "-C", args.build_dir, "-t", "commands", "-s", out], check=True,
                             capture_output=True, text=True).stdout.strip().splitlines()[-1]
        subprocess.run([recorder, log, out, cmd], cwd=args.build_dir, env=env, check=True)
        print(open(log).read().splitlines()[-1], flush=True)


def cmd_wrap(args):
    rules = os.path.join(args.build_dir, "CMakeFiles", "rules.ninja")
    log = os.path.abspath(os.path.join(args.build_dir, "edge_cpu.tsv"))
    recorder = os.path.join(HERE, "edge_cpu.sh")
    text = open(rules).read()
    if "edge_cpu.sh" in text:
        sys.exit(f"{rules}: already wrapped")
    lines = []
    for line in text.splitlines():
        head, sep, command = line.partition("command = ")
        if sep and head.strip() == "" and command:
            if "'" in command:
                sys.exit(f"{rules}: a command with a single quote, which this script cannot wrap: {command}")
            line = f"{head}command = {recorder} {log} \"$out\" {shlex.quote(command)}"
        lines.append(line)
    open(rules, "w").write("\n".join(lines) + "\n")
    open(log, "w").close()
    print(f"{rules}: every step records its CPU seconds in {log}")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    e = sub.add_parser("estimate", help="replay a build through an N-worker schedule")
    e.add_argument("build_dir")
    e.add_argument("--cpu", help="edge_cpu.tsv from a wrapped build: durations = CPU seconds x --scale")
    e.add_argument("--scale", type=float, default=1.0)
    e.add_argument("--log", help="take the logged durations from this .ninja_log instead of the folder's own (the "
                                 "steps another build shares with this one by output name)")
    e.add_argument("--workers", type=int, default=2)
    e.add_argument("--top", type=int, default=0, help="also list the N longest steps")
    c = sub.add_parser("calibrate", help="idle wall / CPU over the steps an idle build and a wrapped build share")
    c.add_argument("idle_dir", help="build folder whose .ninja_log an idle machine recorded")
    c.add_argument("--cpu", required=True)
    c.add_argument("--min-seconds", type=float, default=5.0)
    c.add_argument("-v", "--verbose", action="store_true")
    w = sub.add_parser("wrap", help="make every step of a configured build folder record its CPU time")
    w.add_argument("build_dir")
    m = sub.add_parser("measure", help="build some outputs again (no ccache) and record their CPU seconds")
    m.add_argument("build_dir")
    m.add_argument("--cpu", required=True, help="the edge_cpu.tsv to append to")
    m.add_argument("outputs", nargs="+", help="outputs as build.ninja names them (e.g. apps/CMakeFiles/...o)")
    args = ap.parse_args()
    {"estimate": cmd_estimate, "calibrate": cmd_calibrate, "wrap": cmd_wrap, "measure": cmd_measure}[args.cmd](args)


if __name__ == "__main__":
    main()
