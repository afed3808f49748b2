"""A run analysed without a notebook: where the hot gas is, how fast it
rises, and whether the flow stayed divergence-free.

    smokelab run hot-cold --res 32 --frames 60 --out runs/demo
    python python/examples/analyse_run.py runs/demo

Prints one line per saved frame: time, the hot gas's centre of mass
(x, y, z in world units; y is up), its mean rise speed since the previous
frame, and the largest compact divergence of the velocity at that step.
"""

import sys

import smokelab_xr as sx


def main(path):
    run = sx.open_run(path)
    hot = run.volumes["hot"]  # dims (step, z, y, x); coordinates in world units
    mass = hot.sum(("x", "y", "z"))
    centre = {a: (hot * hot[a]).sum(("x", "y", "z")) / mass for a in "xyz"}
    rise = centre["y"].diff("step") / hot.time.diff("step")  # labelled by step: no index arithmetic
    div = run.metrics.div_max.sel(step=hot.step)  # the metrics of the saved steps
    print("time     x      y      z    rise    div_max")
    for step in hot.step.values:
        speed = float(rise.sel(step=step)) if step in rise.step else float("nan")
        c = [float(centre[a].sel(step=step)) for a in "xyz"]
        print(f"{float(hot.time.sel(step=step)):5.2f} {c[0]:6.3f} {c[1]:6.3f} {c[2]:6.3f} "
              f"{speed:7.4f} {float(div.sel(step=step)):9.2e}")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: python analyse_run.py RUN_DIR")
    try:
        main(sys.argv[1])
    except sx.NotARunError as e:
        print(f"error: {e}", file=sys.stderr)
        sys.exit(2)
