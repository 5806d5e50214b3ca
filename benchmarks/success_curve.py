"""A run's success curve: ``episodes/success_rate`` and the mean reward against frames, as a PNG.

    python benchmarks/success_curve.py RUN_DIR [RUN_DIR ...] --out docs/img/push_cube_success.png \
        [--label NAME ...] [--baseline 0.01] [--title TEXT]

RUN_DIR is a run folder (``runs/<name>_<date-time>``; its ``summaries`` are read). ``--baseline`` draws a
random policy's success rate as a dashed line.
"""

from __future__ import annotations

import argparse
import os


def scalars(run_dir: str, tag: str) -> list[tuple[int, float]]:
    """(step, value) of one TensorBoard tag of a run folder (or its summaries folder)."""
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    path = os.path.join(run_dir, "summaries") if os.path.isdir(os.path.join(run_dir, "summaries")) else run_dir
    events = EventAccumulator(path, size_guidance={"scalars": 0})
    events.Reload()
    if tag not in events.Tags()["scalars"]:
        return []
    return [(e.step, e.value) for e in events.Scalars(tag)]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+")
    parser.add_argument("--out", required=True)
    parser.add_argument("--label", action="append", default=[])
    parser.add_argument("--baseline", type=float, default=None, help="a random policy's success rate")
    parser.add_argument("--title", default="")
    args = parser.parse_args()

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for i, run in enumerate(args.runs):
        label = args.label[i] if i < len(args.label) else os.path.basename(run.rstrip("/"))
        for ax, tag in ((axes[0], "episodes/success_rate"), (axes[1], "rewards/step")):
            points = scalars(run, tag)
            if points:
                ax.plot([p[0] for p in points], [p[1] for p in points], label=label)
    if args.baseline is not None:
        axes[0].axhline(args.baseline, color="gray", linestyle="--", label="random policy")
    axes[0].set_ylabel("success rate (tracked episodes)")
    axes[1].set_ylabel("mean episode reward")
    for ax in axes:
        ax.set_xlabel("frames")
        ax.grid(alpha=0.3)
        ax.legend(loc="best")
    fig.suptitle(args.title)
    fig.tight_layout()
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    fig.savefig(args.out, dpi=80)
    plt.close(fig)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
