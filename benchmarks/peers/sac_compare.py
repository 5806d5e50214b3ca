"""Mean episode reward at equal frames from two TensorBoard runs (rlchain vs rl_games SAC).

Reads the ``rewards/step`` tag (falls back to ``rewards/frame``) that both
libraries write (x = frames, y = running mean of the last ``games_to_track``
episodes) from two run folders, searched recursively for event files, and
prints, for each frame checkpoint, each run's value at its last event at or
before that checkpoint, side by side, with the difference and the ratio
(only when both are positive; HalfCheetah rewards start negative)::

    /work/venv/bin/python benchmarks/peers/sac_compare.py RLCHAIN_DIR RL_GAMES_DIR \
        [--frames 32000 64000 96000] [--tag rewards/step] [--json OUT]

Without ``--frames`` the checkpoints are the frames at which either run's
mean changed (capped at the frames both runs reached). Wall-clock numbers
are printed too but are only comparable when both runs had the same CPU.

``--episodes-per-change E`` (fixed-length episodes where all envs finish
together, e.g. MuJoCo with ``num_actors`` = E) also prints the mean reward of
just the E episodes that finished at each change of the running mean,
recovered from the running means: with n_k = min(k * E, games_to_track),
new_k = (n_k * m_k - (n_k - E) * m_{k-1}) / E while k * E <= games_to_track.
"""

import argparse
import glob
import json
import os
import sys

TAGS = ("rewards/step", "rewards/frame")


def load_run(folder, tag=None):
    """Return {"tag", "events": [(step, value, wall)], "max_frame", "wall": (first, last)} for one run folder."""
    from tensorboard.backend.event_processing import event_accumulator as ea

    paths = glob.glob(os.path.join(folder, "**", "events.out.tfevents.*"), recursive=True)
    dirs = sorted({os.path.dirname(p) for p in paths})
    if not dirs:
        sys.exit(f"no TensorBoard event files under {folder}")
    found = []
    for d in dirs:
        acc = ea.EventAccumulator(d, size_guidance={ea.SCALARS: 0})
        acc.Reload()
        scalars = acc.Tags().get("scalars", [])
        use = tag if tag else next((t for t in TAGS if t in scalars), None)
        if use in scalars:
            found.append((d, acc, use, scalars))
    if not found:
        sys.exit(f"no {tag or ' / '.join(TAGS)} scalars under {folder}")
    if len(found) > 1:
        sys.exit(f"more than one run under {folder}, pass one of: " + ", ".join(f[0] for f in found))
    d, acc, use, scalars = found[0]
    events = sorted((e.step, e.value, e.wall_time) for e in acc.Scalars(use))
    every = [e for t in scalars for e in acc.Scalars(t)]
    return {
        "dir": d,
        "tag": use,
        "events": events,
        "max_frame": max(e.step for e in every),
        "min_frame": min(e.step for e in every),
        "wall": (min(e.wall_time for e in every), max(e.wall_time for e in every)),
    }


def value_at(events, frame):
    """(step, value) of the last event with step <= frame, or None."""
    best = None
    for step, value, _ in events:
        if step > frame:
            break
        best = (step, value)
    return best


def default_frames(a, b):
    """Frames at which either run's mean changed, up to the frames both reached."""
    cap = min(a["max_frame"], b["max_frame"])
    frames = set()
    for run in (a, b):
        prev = None
        for step, value, _ in run["events"]:
            if value != prev and step <= cap:
                frames.add(step)
            prev = value
    frames.add(cap)
    return sorted(frames)


def new_episode_means(events, per_change, games_to_track):
    """[(step, running mean, mean of the newly finished episodes)] at each change of the running mean."""
    out, prev, k = [], None, 0
    for step, value, _ in events:
        if prev is not None and value == prev:
            continue
        k += 1
        if k * per_change > games_to_track:
            new = None  # older episodes dropped out of the window: not recoverable
        elif prev is None:
            new = value
        else:
            new = (k * per_change * value - (k - 1) * per_change * prev) / per_change
        out.append((step, value, new))
        prev = value
    return out


def fmt(v, digits=1):
    return "-" if v is None else f"{v:,.{digits}f}"


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("rlchain", help="rlchain run folder (train_dir or a run under it)")
    p.add_argument("rl_games", help="rl_games run folder (its ./runs or a run under it)")
    p.add_argument("--frames", type=int, nargs="+", help="frame checkpoints (default: where a mean changed)")
    p.add_argument("--tag", default=None, help=f"scalar tag (default: first of {', '.join(TAGS)} present)")
    p.add_argument("--names", nargs=2, default=("rlchain", "rl_games"), metavar=("A", "B"))
    p.add_argument("--episodes-per-change", type=int, default=None,
                   help="episodes finishing at each change of the mean (fixed-length episodes): adds a table of "
                        "the newly finished episodes' mean reward")
    p.add_argument("--games-to-track", type=int, default=100, help="length of both running means (default 100)")
    p.add_argument("--json", default=None, help="also write the table here")
    args = p.parse_args(argv)

    a, b = load_run(args.rlchain, args.tag), load_run(args.rl_games, args.tag)
    na, nb = args.names
    frames = args.frames or default_frames(a, b)
    rows = []
    for f in frames:
        va, vb = value_at(a["events"], f), value_at(b["events"], f)
        ya = None if va is None else va[1]
        yb = None if vb is None else vb[1]
        row = {
            "frames": f,
            na: ya,
            f"{na}_step": None if va is None else va[0],
            nb: yb,
            f"{nb}_step": None if vb is None else vb[0],
            "diff": None if ya is None or yb is None else ya - yb,
            "ratio": ya / yb if ya is not None and yb is not None and ya > 0 and yb > 0 else None,
            "beyond": f > a["max_frame"] or f > b["max_frame"],
        }
        rows.append(row)

    print(f"{na}: {a['dir']} ({a['tag']})")
    print(f"{nb}: {b['dir']} ({b['tag']})")
    head = f"| frames | {na} (at step) | {nb} (at step) | {na} - {nb} | {na} / {nb} |"
    print(head)
    print("|" + " --- |" * 5)
    for r in rows:
        mark = " *" if r["beyond"] else ""
        print(f"| {r['frames']:,}{mark} | {fmt(r[na])} ({fmt(r[f'{na}_step'], 0)}) "
              f"| {fmt(r[nb])} ({fmt(r[f'{nb}_step'], 0)}) | {fmt(r['diff'])} | {fmt(r['ratio'], 2)} |")
    if any(r["beyond"] for r in rows):
        print("* past the last frame one run reached: its value is the last it logged")
    rounds = {}
    if args.episodes_per_change:
        print(f"\nmean reward of the {args.episodes_per_change} episodes finished at each change of the running mean:")
        print(f"| change | {na} (at step) | {nb} (at step) | {na} - {nb} |")
        print("|" + " --- |" * 4)
        ra = new_episode_means(a["events"], args.episodes_per_change, args.games_to_track)
        rb = new_episode_means(b["events"], args.episodes_per_change, args.games_to_track)
        rounds = {na: ra, nb: rb}
        for i in range(max(len(ra), len(rb))):
            xa = ra[i] if i < len(ra) else (None, None, None)
            xb = rb[i] if i < len(rb) else (None, None, None)
            d = None if xa[2] is None or xb[2] is None else xa[2] - xb[2]
            print(f"| {i + 1} | {fmt(xa[2])} ({fmt(xa[0], 0)}) | {fmt(xb[2])} ({fmt(xb[0], 0)}) | {fmt(d)} |")
    summary = {}
    for name, run in ((na, a), (nb, b)):
        wall = run["wall"][1] - run["wall"][0]
        last = run["events"][-1] if run["events"] else None
        summary[name] = {"frames_reached": run["max_frame"], "last_reward": None if last is None else last[1],
                         "last_reward_step": None if last is None else last[0], "event_wall_s": wall,
                         "event_fps": (run["max_frame"] - run["min_frame"]) / wall if wall > 0 else None}
        print(f"{name}: frames reached {run['max_frame']:,}, last mean reward {fmt(summary[name]['last_reward'])} "
              f"at {fmt(summary[name]['last_reward_step'], 0)}; first-to-last event {wall:,.0f} s, "
              f"{(run['max_frame'] - run['min_frame']) / wall if wall > 0 else float('nan'):,.0f} frames/s "
              "(wall clock: not comparable unless both ran on the same idle CPU)")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"rows": rows, "runs": summary, "new_episode_means": rounds}, fh, indent=2)


if __name__ == "__main__":
    main()
