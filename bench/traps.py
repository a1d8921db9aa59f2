"""The trap suite as a user meets it: each trap of data_fixtures/traps.py run by the ``tlsync`` command, timed.

For the quick demo's scene and, when it is here, the real flight
(../shared/real/drone2): per trap, the exit code, the wall time of the
command (a fresh process, as a user runs it: interpreter start and imports
included) and what it names (the error line, or each camera's status and
reason), and whether every pair it left synchronized is right (eps_t <= 1
frame against truth.json). Then the time a project whose video is missing
takes to fail, on the small raw project (videos, checkerboards, GCPs, GPX).

    python bench/traps.py [--real /work/shared/real/drone2] [--only NAME ...]
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from data_fixtures import make_scene, write_scene  # noqa: E402
from data_fixtures.raw_project import SMALL, make_raw_project  # noqa: E402
from data_fixtures.traps import TRAPS  # noqa: E402
from tlsync_pipeline.sync.timeline import eps_t, read_timeline, read_truth  # noqa: E402

TLSYNC = [sys.executable, "-m", "tlsync_pipeline.cli"]


def run(root: Path, *args: str) -> tuple[int, float, str]:
    """(exit code, wall seconds, stderr and stdout) of ``tlsync ARGS root/project.toml -j 1 -q``."""
    start = time.perf_counter()
    done = subprocess.run([*TLSYNC, *args, str(root / "project.toml"), "-j", "1", "-q"], capture_output=True, text=True)
    return done.returncode, time.perf_counter() - start, done.stderr + done.stdout


def outcome(root: Path, code: int, output: str) -> tuple[str, str]:
    """(what the run names, whether what it synchronized is right)."""
    timeline_file = root / "work" / "timeline.json"
    if code == 2 or not timeline_file.exists():
        return next((line for line in output.splitlines() if line.startswith("error:")), output.strip()[-200:]), "-"
    timeline = read_timeline(timeline_file)
    truth, n_frames = read_truth(root / "truth.json")
    wrong = [
        key
        for key, rel in truth.items()
        if set(key.split("->")) <= set(timeline.cameras)
        and not eps_t(timeline.relation(*key.split("->")), rel, n_frames.get(key.split("->")[0]) or 1) <= 1.0
    ]
    named = "; ".join(
        f"{s.camera} {s.status}"
        + (f" ({', '.join(dict.fromkeys(r.code for r in s.reasons if r.severity == s.status))})" if s.reasons else "")
        for s in timeline.statuses().values()
    )
    return named, "no" if wrong else "yes"


def suite(source: Path, label: str, only: list[str]) -> None:
    print(f"\n{label}\n")
    print("| trap | exit | seconds | named | synchronized right |")
    print("|---|---|---|---|---|")
    for name, trap in TRAPS.items():
        if only and name not in only:
            continue
        with tempfile.TemporaryDirectory() as tmp:
            root = Path(tmp) / "project"
            shutil.copytree(source, root, ignore=shutil.ignore_patterns("work"))
            try:
                trap(root)
            except (KeyError, IndexError) as exc:  # a trap that needs what this project does not have
                print(f"| {name} | - | - | not applicable ({exc}) | - |")
                continue
            code, seconds, output = run(root, "sync")
            named, right = outcome(root, code, output)
            print(f"| {name} | {code} | {seconds:.1f} | {named[:160]} | {right} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--real", type=Path, default=Path("/work/shared/real/drone2"))
    parser.add_argument("--only", nargs="*", default=[])
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        quick = Path(tmp) / "quick"
        write_scene(
            make_scene(
                0, lines=((2.0, 4.0), (2.0, 45.0), (1.0, -30.5)), n_frames=(512, 512, 300), tracking_noise_px=1.0
            ),
            quick,
        )
        suite(quick, "Quick demo scene (3 cameras, tracks given)", args.only)
        if (args.real / "project.toml").exists():
            suite(args.real, f"Real flight {args.real} (4 cameras)", args.only)
        else:
            print(f"\nreal flight: skipped ({args.real} not found)")
        raw, _ = make_raw_project(Path(tmp) / "raw", SMALL)
        (raw.parent / "cam2" / "video.mp4").unlink()
        code, seconds, output = run(raw.parent, "run")
        print(
            f"\nraw project with cam2's video missing: exit {code} in {seconds:.1f} s (command start to exit): "
            f"{output.strip().splitlines()[-1][:200]}"
        )


if __name__ == "__main__":
    main()
