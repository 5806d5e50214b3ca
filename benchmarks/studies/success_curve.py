"""A run's success curve: ``episodes/success_rate`` and the mean reward against frames, as a PNG.

    python benchmarks/studies/success_curve.py RUN_DIR [RUN_DIR ...] --out docs/img/push_cube_success.png \
        [--label NAME ...] [--baseline 0.01] [--title TEXT] [--box-target-scale 8 [--distance-baseline 0.09]]

RUN_DIR is a run folder (``runs/<name>_<date-time>``; its ``summaries`` are read); several folders under
one label (``--label`` once per run; repeat a label) are drawn as one curve, a run and its resumption.
``--baseline`` draws a random policy's success rate as a dashed line; ``--smooth N`` averages over N
logged epochs. ``--box-target-scale`` (push-cube runs that log ``env_info/reward_box_target``, see
``log_info_keys``) adds a panel of the planar cube-to-target distance in metres, recovered from that
term as ``benchmarks/studies/push_cube_eval.py`` does; ``--distance-baseline`` draws a random policy's final
distance there.
"""

from __future__ import annotations

import argparse
import os
import sys

if __package__ in (None, ""):  # run by path: this checkout's benchmarks first
    sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))


def scalars(run_dir: str, tag: str) -> list[tuple[int, float]]:
    """(step, value) of one TensorBoard tag of a run folder (or its summaries folder)."""
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    path = os.path.join(run_dir, "summaries") if os.path.isdir(os.path.join(run_dir, "summaries")) else run_dir
    events = EventAccumulator(path, size_guidance={"scalars": 0})
    events.Reload()
    if tag not in events.Tags()["scalars"]:
        return []
    return [(e.step, e.value) for e in events.Scalars(tag)]


def moving_average(values: list[float], n: int) -> list[float]:
    """The mean of each value and the up to ``n - 1`` before it (``n`` <= 1: the values as they are)."""
    if n <= 1:
        return list(values)
    out, total = [], 0.0
    for i, value in enumerate(values):
        total += value - (values[i - n] if i >= n else 0.0)
        out.append(total / min(i + 1, n))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+")
    parser.add_argument("--out", required=True)
    parser.add_argument("--label", action="append", default=[])
    parser.add_argument("--baseline", type=float, default=None, help="a random policy's success rate")
    parser.add_argument("--title", default="")
    parser.add_argument("--box-target-scale", type=float, default=None,
                        help="the runs' env_config.box_target_scale: adds the cube-to-target distance panel")
    parser.add_argument("--distance-baseline", type=float, default=None, help="a random policy's final distance (m)")
    parser.add_argument("--smooth", type=int, default=1, help="moving average over this many logged epochs")
    args = parser.parse_args()

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = [("episodes/success_rate", "success rate (tracked episodes)"), ("rewards/step", "mean episode reward")]
    if args.box_target_scale is not None:
        panels.append(("env_info/reward_box_target", "cube-to-target distance (m)"))
    fig, axes = plt.subplots(1, len(panels), figsize=(5.5 * len(panels), 4))
    curves: dict[str, dict[str, list]] = {}
    for i, run in enumerate(args.runs):
        label = args.label[i] if i < len(args.label) else os.path.basename(run.rstrip("/"))
        for tag, _ in panels:
            curves.setdefault(label, {}).setdefault(tag, []).extend(scalars(run, tag))
    for label, tags in curves.items():
        for ax, (tag, _) in zip(axes, panels):
            points = sorted(tags[tag])
            if not points:
                continue
            values = [p[1] for p in points]
            if tag == "env_info/reward_box_target":
                from benchmarks.studies.push_cube_eval import box_target_distance

                values = box_target_distance(values, args.box_target_scale).tolist()
            ax.plot([p[0] for p in points], moving_average(values, args.smooth), label=label)
    if args.baseline is not None:
        axes[0].axhline(args.baseline, color="gray", linestyle="--", label="random policy")
    if args.distance_baseline is not None and len(panels) > 2:
        axes[2].axhline(args.distance_baseline, color="gray", linestyle="--",
                        label="random actions or a still arm (final)")
    for ax, (_, name) in zip(axes, panels):
        ax.set_ylabel(name)
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
