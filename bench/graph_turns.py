"""Probe: what a turn of a device loop costs on a GPU (CUDA graph conditional nodes).

The solvers' iterations run under ``wp.capture_while`` (a conditional WHILE node: its body graph
is launched again by the device at each turn) and each iteration holds a ``wp.capture_if`` (the
normal solver's recompute, usually false). This times, for an iteration of ``--kernels`` tiny
kernels (one thread each, so launch and scheduling costs are all there is) and M iterations:

- ``straight``: the M iterations captured one after the other, no conditional node (the floor);
- ``while``: one iteration per turn of the loop (the solvers' shape);
- ``while + if``: the same with an IF node (false) in each iteration, as the normal solver has;
- ``unrolled k``: k iterations per turn, the 2nd..k-th each under an IF node on the loop flag
  (same iterations: the loop stops where the flag drops);
- ``nested while``: the iterations in a WHILE node inside the body of another (the normal
  solver's two-level loop: ``ProjectedCG._run``'s prelude);

and prints us per iteration and the overhead over ``straight``.

    python bench/graph_turns.py --device cuda:0 [--kernels 8] [--iterations 1000]
"""

from __future__ import annotations

import argparse
import time

import warp as wp

wp.set_module_options({"enable_backward": False})


@wp.kernel
def touch(a: wp.array(dtype=wp.float64)):
    a[0] = a[0] + wp.float64(1.0)


@wp.kernel
def tick(counter: wp.array(dtype=wp.int32), limit: int, loop: wp.array(dtype=wp.int32),
         inner: wp.array(dtype=wp.int32)):
    counter[0] = counter[0] + 1
    loop[0] = wp.where(counter[0] < limit, 1, 0)
    inner[0] = loop[0]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--device", default="cuda:0")
    ap.add_argument("--kernels", type=int, default=8, help="tiny kernels per iteration (besides the counter)")
    ap.add_argument("--iterations", type=int, default=1000)
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    wp.config.quiet = True
    wp.init()
    device = wp.get_device(args.device)
    if not (device.is_cuda and wp.is_conditional_graph_supported()):
        raise SystemExit("graph_turns: needs a CUDA device with conditional graph nodes")
    m = args.iterations
    a = wp.zeros(1, dtype=wp.float64, device=device)
    counter = wp.zeros(1, dtype=wp.int32, device=device)
    loop = wp.zeros(1, dtype=wp.int32, device=device)
    never = wp.zeros(1, dtype=wp.int32, device=device)
    inner = wp.zeros(1, dtype=wp.int32, device=device)

    def iteration(with_if=False):
        for _ in range(args.kernels):
            wp.launch(touch, 1, [a], device=device)
        if with_if:
            wp.capture_if(never, on_true=lambda: wp.launch(touch, 1, [a], device=device))
        wp.launch(tick, 1, [counter, m, loop, inner], device=device)

    def start():
        counter.zero_()
        loop.fill_(1)

    def unrolled(k, with_if=False):
        def turn():
            iteration(with_if)
            for _ in range(k - 1):
                wp.capture_if(loop, on_true=lambda: iteration(with_if))
        return turn

    def nested():
        inner.fill_(1)
        wp.capture_while(inner, iteration)

    variants = {
        "straight": lambda: [iteration() for _ in range(m)],
        "while": lambda: wp.capture_while(loop, iteration),
        "while + if": lambda: wp.capture_while(loop, lambda: iteration(True)),
        "unrolled 2": lambda: wp.capture_while(loop, unrolled(2)),
        "unrolled 4": lambda: wp.capture_while(loop, unrolled(4)),
        "unrolled 2 + if": lambda: wp.capture_while(loop, unrolled(2, True)),
        "nested while": lambda: wp.capture_while(loop, nested),
    }
    graphs = {}
    with wp.ScopedDevice(device):
        for name, body in variants.items():
            start()
            with wp.ScopedCapture(device=device) as capture:
                start()
                body()
            graphs[name] = capture.graph
        times = {}
        for name, graph in graphs.items():
            best = float("inf")
            for _ in range(args.repeats):
                wp.synchronize_device(device)
                t0 = time.perf_counter()
                wp.capture_launch(graph)
                wp.synchronize_device(device)
                best = min(best, time.perf_counter() - t0)
            assert int(counter.numpy()[0]) == m, (name, counter.numpy())
            times[name] = best
    print(f"# device loop turns: {args.kernels} + 1 one-thread kernels per iteration, {m} iterations; "
          f"device {device} ({device.name}), warp {wp.__version__}, {time.strftime('%Y-%m-%d')}")
    floor = times["straight"] / m
    for name, t in times.items():
        print(f"  {name:16s} {1e6 * t / m:8.2f} us per iteration, {1e6 * (t / m - floor):+8.2f} over straight")


if __name__ == "__main__":
    main()
