"""Print .ci/run's budget: the seconds of each step it timed and the 15 slowest tests of each tier.

Reads the folder .ci/run writes (``start``: the run's start, in seconds since the epoch; ``steps.tsv``: seconds,
exit status, report and label of each timed command, the report being the junit file a tier wrote, ``-`` for
the other steps). The wall clock is the run's length; the steps add up to more than it where one ran in the
background (the mjlab job's install runs beside the main install and the tiers). Standard library only: it
runs after the run's virtual environment may have failed to install.
"""

import os
import sys
import time
import xml.etree.ElementTree as ET

SLOWEST = 15


def steps(folder: str) -> list[tuple[int, int, str, str]]:
    path = os.path.join(folder, "steps.tsv")
    if not os.path.exists(path):
        return []
    rows = []
    with open(path) as f:
        for line in f:
            seconds, rc, report, label = line.rstrip("\n").split("\t", 3)
            rows.append((int(seconds), int(rc), report, label))
    return rows


def wall(folder: str) -> int | None:
    """Seconds since the run started, or None when the run left no start time."""
    path = os.path.join(folder, "start")
    if not os.path.exists(path):
        return None
    with open(path) as f:
        return int(time.time()) - int(f.read().strip())


def group(label: str) -> str:
    """The budget line a timed command counts toward: the installs of a job, or its tier."""
    head, sep, _ = label.partition("install: ")
    return head + "install" if sep else label


def tier(path: str) -> tuple[dict, list[tuple[float, str]]]:
    """(counts, [(seconds, test id)]) of one junit report."""
    root = ET.parse(path).getroot()
    counts = {"passed": 0, "failed": 0, "skipped": 0, "seconds": 0.0}
    times = []
    for case in root.iter("testcase"):
        seconds = float(case.get("time") or 0.0)
        counts["seconds"] += seconds
        if case.find("failure") is not None or case.find("error") is not None:
            counts["failed"] += 1
        elif case.find("skipped") is not None:
            counts["skipped"] += 1
        else:
            counts["passed"] += 1
        name = f"{case.get('classname', '').replace('.', '/')}.py::{case.get('name')}"
        times.append((seconds, name))
    times.sort(reverse=True)
    return counts, times


def main(folder: str) -> None:
    rows = steps(folder)
    print("\n========== CI budget (seconds) ==========")
    totals: dict[str, int] = {}
    failed = {}
    for seconds, rc, _report, label in rows:
        key = group(label)
        totals[key] = totals.get(key, 0) + seconds
        if rc:
            failed[key] = rc
    for key, seconds in totals.items():
        mark = f"   FAILED (exit {failed[key]})" if key in failed else ""
        print(f"{seconds:7d}  {key}{mark}")
    print(f"{sum(totals.values()):7d}  total of the timed steps")
    seconds = wall(folder)
    if seconds is not None:
        print(f"{seconds:7d}  wall clock of the whole run")
    passed = fails = 0
    for seconds, _rc, report, label in rows:
        path = os.path.join(folder, report)
        if report == "-" or not os.path.exists(path):
            continue
        counts, times = tier(path)
        passed += counts["passed"]
        fails += counts["failed"]
        top = sum(t for t, _ in times[:SLOWEST])
        print(f"\n--- {label}: {seconds} s wall; {counts['passed']} passed, {counts['failed']} failed, "
              f"{counts['skipped']} skipped; {counts['seconds']:.0f} s of test time, the {SLOWEST} slowest "
              f"{top:.0f} s ({100 * top / max(counts['seconds'], 1e-9):.0f}%)")
        for t, name in times[:SLOWEST]:
            print(f"{t:8.1f}  {name}")
    print(f"\nbudget: {passed} passed, {fails} failed")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else ".ci-budget")
