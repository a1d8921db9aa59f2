"""Failures as one plain line: what the command line prints and status records."""

import errno

from tlsync_pipeline.errors import (
    MAX_REASON,
    EnvironmentProblem,
    InputError,
    describe_error,
    one_line,
    os_error_problem,
)


def test_a_reason_is_one_line_of_bounded_length():
    text = "cam1/track.csv:3: column 'x':\n   not a number " + "x" * 5000
    line = one_line(text)
    assert "\n" not in line and len(line) == MAX_REASON and line.endswith(" ...")
    assert line.startswith("cam1/track.csv:3: column 'x': not a number ")


def test_os_errors_name_the_path_and_say_what_went_wrong():
    full = OSError(errno.ENOSPC, "No space left on device", "/data/work/timeline.json")
    assert isinstance(os_error_problem(full), EnvironmentProblem)
    assert describe_error(full) == "/data/work/timeline.json: the disk is full"
    assert isinstance(
        os_error_problem(FileNotFoundError(errno.ENOENT, "No such file or directory", "/data/cam0.mp4")), InputError
    )
    assert describe_error(KeyError("cameras")) == "unexpected KeyError: 'cameras'"


def test_a_path_too_long_says_so_on_one_short_line():
    """At PATH_MAX the reason, not the middle of the path, reaches the terminal; a too-long name is bad input."""
    path = "/data/" + "/".join(["d" * 200] * 25) + "/project.toml"
    problem = os_error_problem(OSError(errno.ENAMETOOLONG, "File name too long", path))
    assert isinstance(problem, InputError)
    text = str(problem)
    assert (
        len(text) < 200 and text.startswith("/data/ddd") and "project.toml: file name too long (5043 characters" in text
    )
