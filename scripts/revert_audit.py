"""Does each fix's test fail without its fix? Issue 59's items, each fix reversed in a clone of this checkout.

For every item: a clone at HEAD, the item's fix commits reversed in it (their code, or for a tolerance that was
the fix, their tests), and the item's tests run there with this interpreter (the clone first on PYTHONPATH, so
the processes the tests launch run the clone's code too). A test that still passes without its fix proves
nothing: the table says so. The same tests are run on the unchanged clone first.

Usage: python -m scripts.revert_audit [--items 1,4,25] [--timeout 300] [--out FILE.md]
"""

from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
P, K, F, T, C = ("tests/test_precice.py", "tests/test_kratos_cases.py", "tests/test_fmi3.py", "tests/test_time.py",
                 "tests/test_cli_errors.py")
MISUSE = f"{P}::test_a_participant_misusing_the_api_stops_the_run_in_one_line_naming_the_call"
BAD_CONFIG = f"{P}::test_a_bad_configuration_is_one_line_with_its_file_and_line"
BAD_KRATOS = f"{K}::test_a_bad_cosimulation_file_is_one_line_naming_its_file_line_and_key"


@dataclass
class Item:
    """An item of the audit: the commits that fixed it and the tests that hold it."""

    label: str
    commits: list[str]
    tests: list[str]
    part: str = "code"                      # what of the commits is reversed: "code" (all but tests) or "tests"
    env: dict[str, str] = field(default_factory=dict)
    paths: list[str] = field(default_factory=list)  # only these files of the commits (where a commit did more)
    #: where later commits rewrote the fix's lines, the fix taken out by hand: (file, the fix's text, without it)
    undo: list[tuple[str, str, str]] = field(default_factory=list)


CONNECTION = "precice_compat/participant/precice/_connection.py"
ZOMBIES = [("cosim/rundir.py", "    return not zombie(pid)\n", "    return True\n"),
           (CONNECTION, '    return _proc(pid, "stat").rpartition(")")[2][1:2] != "Z"\n', "    return True\n")]
TRUSTED = [(CONNECTION, "    if not stat.S_ISREG(status.st_mode) or status.st_uid != os.getuid() or status.st_mode & 0o022:",
            "    if False:")]
NO_COUPLER = [(CONNECTION, "    if not _listens(pid, endpoint):", "    if False:"),
              (CONNECTION, '    if not _alive(pid) or (command and "cosim" not in command):', "    if not _alive(pid):")]
SECOND = [("cosim/participant.py", 'if isinstance(other, int) and other != os.getpid() and alive(other) and "cosim" in '
           'command_line(other):', "if False:")]
LEFT_BEHIND = [("coupler/run.py", "    except BaseException:\n        if hub is not None:\n            hub.close()\n        raise",
                "    except BaseException:\n        raise")]
UNTRUSTED_DATA = [("cosim/participant.py", "            if value.dtype != np.float64:", "            if False:"),
                  ("cosim/participant.py", "        if isinstance(pid, bool) or not isinstance(pid, int) or pid < 0:",
                   "        if False:"),
                  ("cosim/participant.py", "            if vertices.dtype != np.float64 or vertices.ndim != 2 or "
                   "(dimensions and vertices.shape[1] != dimensions):", "            if False:")]

ITEMS = [
    Item("1", ["5fb1127"], [f"{K}::test_a_kratos_case_resumes_only_with_the_solvers_files_it_started_with"]),
    Item("2", ["df4628c"], [f"{T}::test_a_non_finite_value_at_a_step_inside_the_window_is_named_at_its_sender"]),
    Item("3", ["5e73ac0"], [f"{F}::test_an_fmi3_fmu_of_another_maker_couples_and_one_that_cannot_roll_back_is_refused"],
         paths=["fmu_component"]),
    Item("4", ["60e4768"], [f"{BAD_KRATOS}[an end time of 1e9]", f"{BAD_KRATOS}[an infinite end time]"]),
    Item("5", ["dd34736", "e040cf6"], undo=ZOMBIES, tests=[f"{P}::test_a_participant_waiting_on_a_coupler_that_died_unreaped_sees_it_gone",
                                       f"{P}::test_a_rendezvous_naming_a_live_program_that_is_no_coupler_or_a_zombie_is_stale"]),
    Item("6", ["224a2e4"], [f"{P}::test_what_a_participant_started_is_stopped_with_it"]),
    Item("7 (start-up failure)", ["dd34736", "e040cf6"], undo=LEFT_BEHIND,
         tests=[f"{P}::test_a_coupler_that_fails_at_start_up_leaves_no_rendezvous_behind"]),
    Item("7 (second coupler)", ["dd34736"], undo=SECOND,
         tests=[f"{P}::test_a_second_coupler_for_the_same_configuration_is_refused_not_overwriting_the_first"]),
    Item("7 (live pid)", ["dd34736", "dd85922"], undo=NO_COUPLER,
         tests=[f"{P}::test_a_rendezvous_naming_a_live_program_that_is_no_coupler_or_a_zombie_is_stale"]),
    Item("8", ["31d25a7"], undo=[("coupler/waveform.py", "while held[0] > CACHE_BYTES and len(kept) > 1:", "while False:"),
                                 ("cosim/participant.py", "if times.size >= MAX_SUBSTEPS:", "if False:")], tests=[f"{T}::test_the_waveforms_matrices_kept_per_time_grid_hold_a_bounded_number_of_bytes",
                            f"{P}::test_a_participant_taking_more_steps_in_a_window_than_a_waveform_holds_is_named"]),
    Item("9", ["d5a8492"], [f"{C}::test_special_files_named_as_inputs_are_refused_at_once"],
         undo=[("cosim/input_file.py", "        if not stat.S_ISREG(mode):", "        if False:")]),
    Item("14", ["d5a8492"], [f"{C}::test_special_files_named_as_inputs_are_refused_at_once"],
         undo=[("cosim/rundir.py", "    if not isinstance(status, dict):\n        return {}                   # damaged: a "
                "status is a table\n    status = _well_formed(status)\n", "")]),
    Item("10", ["5977d0a"], [f"{F}::test_bad_fmi3_fmus_are_refused_in_one_line"]),
    Item("11", ["dd34736"], undo=TRUSTED, tests=[f"{P}::test_a_rendezvous_file_that_another_could_have_written_is_not_trusted"]),
    Item("12", ["55c846c"], [f"{K}::test_a_solver_s_bad_parameters_are_one_line_naming_the_key",
                             f"{K}::test_the_json_reader_takes_what_kratos_takes_and_refuses_what_it_refuses"]),
    Item("13", ["4cb721e"], undo=UNTRUSTED_DATA, tests=[f"{P}::test_a_participant_sending_what_no_participant_sends_stops_the_run_in_one_line",
                             f"{P}::test_timings_that_are_no_numbers_are_left_out_not_a_crash"]),
    Item("15", ["491662d"], undo=[("coupler/run_log.py", "        if len(fields) != len(columns):\n            continue\n"
                                   "        try:\n            table.append([float(v) for v in fields])\n        except "
                                   "ValueError:\n            continue\n", "        table.append([float(v) for v in fields])\n")],
         tests=["tests/test_monitor.py::test_the_convergence_plot_reads_damaged_or_unfinished_logs_and_never_writes_over_the_run"]),
    Item("16", ["b1ba1d6"], undo=[("precice_compat/config.py", "            if not file_name_part(name):", "            if False:"),
                                  ("cosim/watch_points.py", 'if not isinstance(point["name"], str) or not '
                                   'file_name_part(point["name"]):', "if False:")], tests=[f"{BAD_CONFIG}[a watch point named as a path]",
                             "tests/test_scene.py::test_set_overrides_values_and_records_them"]),
    Item("17", ["0263a12"], [f"{BAD_CONFIG}[a window of 0 s]", f"{BAD_CONFIG}[a max-time of 0 s]"]),
    Item("18 (fmpy)", ["546b7b3"], undo=[("fmu_component/archive.py", '    text = " ".join(line.strip() for line in '
                                          'str(exc).splitlines() if line.strip())', '    text = (str(exc).splitlines() or [""])[0]'),
                                         ("fmu_component/archive.py", '    if len(text.strip(": ")) < 8:', "    if False:")], tests=["tests/test_fmu.py::test_an_exceptions_whole_message_goes_on_one_line"]),
    Item("18 (interface.json)", ["546b7b3", "1d74467"], undo=[
        ("fmu_component/component.py", "            except (ValueError, UnicodeDecodeError) as exc:",
         "            except UnicodeDecodeError as exc:")], tests=["tests/test_fmu.py::test_a_damaged_interface_json_is_named_in_one_line"]),
    Item("18 (newlines, %g)", ["afe9ccb"], undo=[
        ("cosim/participant.py", '    text = " ".join(str(message).split())\n    return text if len(text) <= MAX_MESSAGE else '
         'text[:MAX_MESSAGE - 3] + "..."', "    return str(message)"),
        ("precice_compat/participant/precice/_core.py", "    return short if short[0] != short[1] or a == b else "
         "(repr(float(a)), repr(float(b)))", "    return short")], tests=[f"{MISUSE}[an error of megabytes on one line]",
                                             f"{MISUSE}[a step a hair beyond the window]"]),
    Item("18 (warnings)", ["6391eed"], ["tests/test_faults.py::test_numpys_warnings_are_not_printed_above_the_error_line"]),
    Item("19", ["55c846c"], [f"{K}::test_the_json_reader_takes_what_kratos_takes_and_refuses_what_it_refuses"]),
    Item("20", ["ef2ef75"], ["tests/test_restart.py::test_a_damaged_component_state_in_a_checkpoint_is_refused_by_its_digest"]),
    Item("21", ["78ff741"], undo=[("precice_compat/participant/precice/_core.py", "if not np.isfinite(relative_read_time) "
                                  "or relative_read_time < 0", "if relative_read_time < 0")], tests=[f"{MISUSE}[a read at a NaN time]"]),
    Item("22", ["b2c96a8"], undo=[("kratos_compat/cosim_parameters.py", "if threads is not None and not 1 <= threads <= most:",
                                  "if False:")], tests=[f"{BAD_KRATOS}[100000 threads]"]),
    Item("23", ["45a8f27"], undo=[("fmu_component/component.py", "if not self.inputs and not self.outputs:",
                                  "if not self.inputs or not self.outputs:")],
         tests=[f"{F}::test_an_fmu_with_outputs_alone_drives_a_solver_one_way_and_its_other_variables_stay_its_own"]),
    Item("24", ["45a8f27"], undo=[("fmu_component/fmi3_instance.py", "                    self.skipped[v.name] = "
                                   "f\"{v.causality} '{v.name}' is {v.type}; only Float64 variables can be coupled\"",
                                   "                    raise FmiError(f\"{v.causality} '{v.name}' is {v.type}; only "
                                   "Float64 variables can be coupled\")")],
         tests=[f"{F}::test_an_fmu_with_outputs_alone_drives_a_solver_one_way_and_its_other_variables_stay_its_own"]),
    *(Item(f"25 ({kernel})", ["6e5640b", "50e4077"],
           [f"{F}::test_an_fmi3_fmu_of_another_maker_couples_and_one_that_cannot_roll_back_is_refused"], part="tests",
           env={"OPENBLAS_CORETYPE": kernel}) for kernel in ("SkylakeX", "Haswell", "Sandybridge", "Prescott")),
    Item("25 (Katmai)", ["6bf82dc"], ["tests/test_coupler_math.py::test_cell_interpolation_is_exact_on_linear_fields_"
                                      "inside_the_cells_and_conserves_sums"], part="tests",
         env={"OPENBLAS_CORETYPE": "Prescott"}),
    *(Item(f"25 ({kernel})", ["84e5af5"], ["tests/test_faults.py::test_a_run_with_no_finished_window_has_empty_window_"
                                           "datasets"], part="tests", env={"OPENBLAS_CORETYPE": kernel})
      for kernel in ("Sandybridge", "Haswell", "Prescott")),
    Item("25 (Nehalem)", ["b7f9ec8"], ["tests/test_rom_integration.py::test_a_rom_out_of_its_range_warns_or_hands_the_call_"
                                       "to_the_solid_fom"], part="tests", env={"OPENBLAS_CORETYPE": "Nehalem"}),
    Item("min above max", ["b1ba1d6"], undo=[("precice_compat/config.py", 'if scheme.get("min_iterations", 1) > '
                                             'scheme.get("max_iterations", 100):', "if False:")], tests=[f"{BAD_CONFIG}[min-iterations above max-iterations]"]),
    Item("another's name", ["78fa551"], [f"{P}::test_a_launched_participant_cannot_say_hello_as_another"]),
    Item("cosim-kratos-* folders", ["1174f05"], undo=[("cosim/launcher.py", "shutil.rmtree(self._scratch, "
                                                      "ignore_errors=True)", "pass")],
         tests=["tests/test_integration.py::test_crashing_component_is_named_with_its_exit_code_and_log"]),
]


def git(clone: Path, *args: str, stdin: str | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(["git", "-C", str(clone), *args], input=stdin, capture_output=True, text=True)


def reset(clone: Path) -> None:
    git(clone, "checkout", "-q", "-f", "HEAD")
    git(clone, "clean", "-q", "-f", "-d", "--", ".")


def reverse(clone: Path, item: Item) -> str:
    """Reverse the item's commits in the clone, newest first (or take its fix out by hand: ``undo``); '' or why it
    could not."""
    if item.undo:
        for path, fix, without in item.undo:
            text = (clone / path).read_text()
            if text.count(fix) != 1:
                return f"{path}: the fix's text is not there once (no hunk reverses)"
            (clone / path).write_text(text.replace(fix, without))
        return "by hand: " + ", ".join(sorted({path for path, _, _ in item.undo}))
    pathspec = ["--", *item.paths] if item.paths else ["--", "tests"] if item.part == "tests" else [
        "--", ".", ":(exclude)tests", ":(exclude)docs", ":(exclude)CHANGELOG.md"]
    notes = []
    for commit in item.commits:
        patch = git(clone, "show", "--format=", commit, *pathspec).stdout
        done = git(clone, "apply", "-R", "--3way", "-", stdin=patch)
        if done.returncode == 0 and not git(clone, "diff", "--name-only", "--diff-filter=U").stdout.strip():
            continue
        # later commits changed the same lines: reverse the hunks that still fit, and say how many did not
        for path in git(clone, "diff", "--name-only").stdout.split() + git(clone, "diff", "--cached", "--name-only").stdout.split():
            git(clone, "checkout", "-q", "HEAD", "--", path)
        done = git(clone, "apply", "-R", "--reject", "-", stdin=patch)
        rejected = done.stderr.count("Rejected hunk")
        applied = done.stderr.count("Applied patch") + done.stderr.count("applied cleanly")
        if rejected:
            notes.append(f"{commit}: {rejected} hunk{'s' if rejected > 1 else ''} left (changed since)")
        if not git(clone, "diff", "--name-only").stdout.strip() and not applied:
            return f"{commit}: no hunk reverses"
        git(clone, "clean", "-q", "-f", "--", "*.rej")
    return "; ".join(notes)


def pytest(clone: Path, item: Item, timeout: float) -> tuple[str, str, float]:
    """Run the item's tests in the clone: ('passed' | 'failed' | 'timed out', the first failure line, seconds)."""
    env = {**os.environ, **item.env, "PYTHONPATH": str(clone)}
    started = time.monotonic()
    process = subprocess.Popen([sys.executable, "-m", "pytest", "-q", "-x", "-p", "no:cacheprovider", *item.tests],
                               cwd=clone, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                               start_new_session=True)
    try:
        out, _ = process.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        process.communicate()
        return "timed out", f"after {timeout:.0f} s", time.monotonic() - started
    finally:
        try:
            os.killpg(process.pid, signal.SIGKILL)      # whatever the tests left behind
        except ProcessLookupError:
            pass
    seconds = time.monotonic() - started
    if process.returncode == 0:
        return "passed", "", seconds
    reason = next((line for line in out.splitlines() if line.startswith("E ")), "")
    if not reason:
        reason = next((line for line in reversed(out.splitlines()) if "failed" in line or "error" in line), "")
    return "failed", reason[:160].replace("|", "/"), seconds


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--items", default="", help="comma-separated item labels' leading numbers (default: all)")
    parser.add_argument("--timeout", type=float, default=300.0, help="seconds for one item's tests")
    parser.add_argument("--out", type=Path, help="also write the table to this markdown file")
    arguments = parser.parse_args()
    wanted = {label.strip() for label in arguments.items.split(",") if label.strip()}
    items = [item for item in ITEMS if not wanted or item.label.split(" ")[0].rstrip(",") in wanted]
    head = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True,
                          text=True).stdout.strip()
    rows = [f"revert audit of {head}: each item's tests at HEAD, then with its fix reversed", "",
            "| item | fix reversed | at HEAD | without the fix | s | first failure |", "| --- | --- | --- | --- | --- | --- |"]
    print("\n".join(rows), flush=True)
    with tempfile.TemporaryDirectory(prefix="revert-audit-") as scratch:
        clone = Path(scratch) / "clone"
        subprocess.run(["git", "clone", "-q", "--no-hardlinks", str(ROOT), str(clone)], check=True)
        for item in items:
            reset(clone)
            at_head, _, _ = pytest(clone, Item(item.label, [], item.tests, env=item.env), arguments.timeout)
            why = reverse(clone, item)
            if why.endswith("no hunk reverses)") or why.endswith("no hunk reverses"):
                outcome, reason, seconds = "not run", why, 0.0
            else:
                outcome, reason, seconds = pytest(clone, item, arguments.timeout)
                reason = f"{why}; {reason}" if why else reason
            env = " ".join(f"{key}={value}" for key, value in item.env.items())
            what = " ".join(item.commits) + (f" ({', '.join(item.paths)})" if item.paths else " (tests)"
                                             if item.part == "tests" else "") + (f", {env}" if env else "")
            if item.undo:
                what += " (by hand)"
            row = f"| {item.label} | {what} | {at_head} | {outcome} | {seconds:.0f} | {reason} |"
            rows.append(row)
            print(row, flush=True)
    if arguments.out:
        arguments.out.write_text("\n".join(rows) + "\n")
    good = all(row.split("|")[3].strip() == "passed" and row.split("|")[4].strip() in ("failed", "timed out")
               for row in rows[4:])
    return 0 if good else 1


if __name__ == "__main__":
    sys.exit(main())
