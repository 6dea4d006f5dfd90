"""Command line: ``cablefem run|modes|post|fatigue|compare|keys|batch``.

Exit codes: 0 success; 1 a solve failed (the files written so far are valid and
``summary.json`` says why); 2 bad input (case file, options, CSV), reported one line per
problem before any expensive work, without a traceback; 3 with ``--strict``, the run finished
but warned (its warnings are listed under ``warnings`` in ``summary.json``); 128 + the
signal's number (130 for
Ctrl-C, 143 for SIGTERM) when a run was stopped by a signal: in the dynamics every file is
valid and ``cablefem run --restart DIR`` continues it from its last checkpoint; before them
(build, statics, modes) there is nothing to resume. The output folder is checked (a
writable directory) and locked against a second run before any work (exit 2 otherwise);
see docs/running.md.

PETSc options go after the other arguments, e.g. ``cablefem run case.toml --output out
-cable_ts_type alpha2 -cable_snes_monitor``; every solver has the ``cable_`` prefix
(``cable_static_`` for statics, ``cable_modal_`` for the eigensolver).
"""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

__all__ = ["main"]

EXIT_OK, EXIT_FAILED, EXIT_INPUT, EXIT_WARNED = 0, 1, 2, 3


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line, exit 2, no usage dump
        sys.stderr.write(f"cablefem: error: {message} (see 'cablefem {self.prog.split()[-1]} "
                         "--help')\n" if " " in self.prog else f"cablefem: error: {message}\n")
        raise SystemExit(EXIT_INPUT)


def _common(sp: argparse.ArgumentParser, restartable: bool = False) -> None:
    """The case, output folder, ``--quiet`` and ``--strict`` of ``run`` and ``modes``."""
    if restartable:
        sp.add_argument("case", type=Path, nargs="?", help="case file (TOML); not "
                        "needed with --restart")
        sp.add_argument("--output", "-o", type=Path, help="output folder")
        sp.add_argument("--restart", type=Path, metavar="DIR",
                        help="continue the run in DIR from its last checkpoint (after "
                             "Ctrl-C, SIGTERM, a kill or a crash)")
    else:
        sp.add_argument("case", type=Path, help="case file (TOML)")
        sp.add_argument("--output", "-o", type=Path, required=True, help="output folder")
    sp.add_argument("--quiet", "-q", action="store_true", help="warnings and errors only")
    sp.add_argument("--strict", action="store_true",
                    help="exit 3 when the run warns (input out of the method's range, "
                         "implausible values, ...): the warnings are in summary.json")


def _add_run(sub, keys: str) -> None:
    run = sub.add_parser("run", formatter_class=argparse.RawDescriptionHelpFormatter,
                         help="statics, modes and dynamics of a case",
                         description="Static equilibrium, modal analysis and (with a "
                         "[dynamics] table) time integration; anchor forces and moments.\n"
                         "Writes summary.json, anchors.csv, string.xdmf, modes.xdmf, "
                         "moments.xdmf, figures.",
                         epilog="Case file keys:\n\n" + keys)
    _common(run, restartable=True)
    run.add_argument("--t-end", type=float, help="override dynamics.t_end (s)")
    run.add_argument("--model", choices=["string", "beam", "auto"], default=None,
                     help="'string' (default): the string + asymptotics; 'beam': the "
                          "reference rod (geometrically exact, graded mesh, [beam] table); "
                          "'auto': the string, then the rod where the string's estimated "
                          "moment error exceeds 2 %% (default: solver.model)")
    run.add_argument("--refine", type=float, default=None,
                     help="beam: scale the mesh density ([beam] layer_elements and "
                          "span_elements), > 0; default 1")
    run.add_argument("--outer-correction", choices=["none", "hinge"], default=None,
                     help="string: override solver.outer_correction ('hinge', the default: "
                          "the string pinned at a virtual hinge near each clamp, first order "
                          "in the layer length; 'none': the paper's leading order)")
    run.add_argument("--moment-form", choices=["exact", "explicit"], default="exact",
                     help="anchor moment from the exact first integral (default) or the "
                          "paper's explicit form")
    run.add_argument("--no-figures", action="store_true", help="skip the PNG figures")
    run.add_argument("--static-only", action="store_true", help="skip the dynamics")


def _add_modes(sub, keys: str) -> None:
    modes = sub.add_parser("modes", formatter_class=argparse.RawDescriptionHelpFormatter,
                           help="static equilibrium and natural modes",
                           description="Static equilibrium and the lowest natural modes "
                           "(SLEPc); writes summary.json, modes.xdmf.",
                           epilog="Case file keys:\n\n" + keys)
    _common(modes)
    modes.add_argument("--n", type=int, help="number of modes (default: modal.modes)")
    modes.add_argument("--outer-correction", choices=["none", "hinge"], default=None,
                       help="override solver.outer_correction")


def _add_post(sub) -> None:
    post = sub.add_parser("post", help="anchor moments from another solver's anchor forces",
                          formatter_class=argparse.RawDescriptionHelpFormatter,
                          description="Apply the inner (boundary-layer) solution to "
                          "anchor-force histories from any string solver.\n\n"
                          "CSV: columns time, anchor, Nx, Ny, Nz (others ignored), one row "
                          "per time and anchor;\nanchor names as in the case. Sign "
                          "convention: N is the force that the SPAN exerts on\nthe ANCHOR, "
                          "i.e. the cable tension times the unit tangent pointing from the\n"
                          "anchor into the span (what 'cablefem run' writes). Solvers that "
                          "export the\nreaction, the force of the anchor on the cable, "
                          "give the opposite sign: use\n--sign anchor (multiplies N by -1). "
                          "A force pointing more than 90 degrees away\nfrom the clamp "
                          "direction is no boundary layer the method describes: such rows\n"
                          "get valid = 0; when most rows of an anchor are like that, the "
                          "file is refused\n(exit 2). See docs/post.md.")
    post.add_argument("forces", type=Path, help="anchor-force CSV")
    post.add_argument("--sign", choices=["span", "anchor"], default="span",
                      help="whose force the CSV holds: 'span' (default), the force of the "
                           "span on the anchor, pointing into the span; 'anchor', the force "
                           "of the anchor on the cable (a reaction): flipped before use")
    post.add_argument("--case", type=Path, required=True, help="case file (TOML)")
    post.add_argument("--output", "-o", type=Path, required=True, help="output folder")
    post.add_argument("--moment-form", choices=["exact", "explicit"], default="exact")
    post.add_argument("--quiet", "-q", action="store_true")


def _add_fatigue(sub) -> None:
    fat = sub.add_parser("fatigue", help="fatigue damage at the clamped anchors and kinks "
                         "of a run",
                         description="Axial + bending stress at the clamped anchors from DIR/"
                         "anchors.csv and at the interior kinks from DIR/kinks.csv (if there; "
                         "reported as 'kink:<name>'), at the worst direction round the "
                         "section, rainflow counting, Miner's damage with the S-N curve of "
                         "the case's [fatigue] table; writes fatigue.json, fatigue.md and "
                         "fatigue_histogram.png. Area and modulus: fatigue.area and "
                         "fatigue.modulus if given (for every location), else the solid "
                         "circle of the section's diameter: in a network, the section of the "
                         "anchor's cable (from DIR/summary.json) or of the cable group a "
                         "kink's name ends with. Fields: docs/fatigue.md.")
    fat.add_argument("rundir", type=Path, help="folder of a run (with anchors.csv)")
    fat.add_argument("--case", type=Path, required=True, help="case file (TOML) with [fatigue]")
    fat.add_argument("--output", "-o", type=Path, help="output folder (default: rundir)")
    fat.add_argument("--window", choices=["after_startup", "all", "steady"],
                     help="after the motions' start-up, the whole run or its statistics "
                          "window (from dynamics.statistics_start, else the last third; "
                          "default: fatigue.window)")
    fat.add_argument("--invalid", choices=["raise", "drop"], default="raise",
                     help="samples without a valid moment (slack anchor): stop (default) or "
                          "leave them out (the valid samples are then joined into one "
                          "history)")
    fat.add_argument("--quiet", "-q", action="store_true")


def _add_compare(sub) -> None:
    cmp_ = sub.add_parser("compare", help="compare two runs of a case (e.g. string and beam)",
                          description="Compare two finished run folders, typically 'cablefem "
                          "run CASE -o A' and 'cablefem run CASE --model beam -o B': static "
                          "moment and tension, steady-state peak and RMS of |M| (the last "
                          "third of the common time range, or from both runs' "
                          "dynamics.statistics_start) at every clamped anchor and kink, first "
                          "natural "
                          "frequency, wall times; relative differences (b-a)/a. Prints a "
                          "table; writes compare.json, compare.md and compare_<anchor>.png.")
    cmp_.add_argument("dir_a", type=Path, help="folder of run a (the reference of the "
                      "relative differences)")
    cmp_.add_argument("dir_b", type=Path, help="folder of run b")
    cmp_.add_argument("--output", "-o", type=Path, help="output folder (default: dir_b)")
    cmp_.add_argument("--quiet", "-q", action="store_true",
                      help="no table on stdout; warnings and errors only")


def _add_keys(sub) -> None:
    keys_ = sub.add_parser("keys", help="print every case-file key with its unit and range")
    keys_.add_argument("--network", action="store_true",
                       help="the keys of a network case ([network], [[cables]], ...)")
    keys_.add_argument("--loadset", action="store_true",
                       help="the keys of a load-case set file ('cablefem batch')")


def _add_batch(sub) -> None:
    b = sub.add_parser("batch", help="every case and seed of a load-case set, and the "
                       "design (fatigue over the design life, extremes)",
                       description="Run every load case and seed of a set file into "
                       "DIR/<case>/seed<k>/ (the outputs of 'cablefem run'), on one process "
                       "or under mpirun -n P (groups of --ranks-per-case ranks take runs from "
                       "a queue); then DIR/design.json and its figures. Run the same command "
                       "again to resume a killed batch. Exit 0: every run completed; 1: a "
                       "run failed (the design is incomplete); 2: bad input, before any run; "
                       "128 + signal: stopped by a signal. Set-file keys: 'cablefem keys "
                       "--loadset'; docs/loadsets.md.")
    b.add_argument("set", type=Path, help="load-case set file (TOML)")
    b.add_argument("--output", "-o", type=Path, required=True, help="output folder")
    b.add_argument("--t-end", type=float, help="override every case's dynamics.t_end (s)")
    b.add_argument("--ranks-per-case", type=int, default=1,
                   help="ranks per run (a divisor of the number of ranks; default 1)")
    b.add_argument("--no-figures", action="store_true",
                   help="no figures of the single runs (the design's are drawn)")
    b.add_argument("--quiet", "-q", action="store_true", help="warnings and errors only")


def _batch(args) -> int:
    """``cablefem batch``: the set checked in full before any run."""
    from mpi4py import MPI

    from cablefem.app.batch import run_batch
    from cablefem.app.log import setup_logging
    from cablefem.case import CaseError
    from cablefem.case.loadset import load_loadset

    if args.t_end is not None and not args.t_end > 0:
        return _input_error(f"--t-end must be > 0 (s), got {args.t_end}")
    size = MPI.COMM_WORLD.size
    if args.ranks_per_case < 1 or size % args.ranks_per_case:
        return _input_error(f"--ranks-per-case must be >= 1 and divide the number of "
                            f"ranks ({size}), got {args.ranks_per_case}")
    try:
        ls = load_loadset(args.set, t_end=args.t_end)
    except CaseError as err:
        if MPI.COMM_WORLD.rank == 0:
            sys.stderr.write(str(err) + "\n")
        return EXIT_INPUT
    setup_logging(logging.WARNING if args.quiet else logging.INFO)
    try:
        res = run_batch(ls, args.output, ranks_per_case=args.ranks_per_case,
                        figures=not args.no_figures)
    except ValueError as err:  # OutdirError included
        return _input_error(str(err))
    if res.signal:
        return 128 + res.signal
    return EXIT_OK if res.design.get("complete") and not res.failed else EXIT_FAILED


def _parser() -> argparse.ArgumentParser:
    from cablefem.case import format_case_reference

    keys = format_case_reference()
    p = _Parser(prog="cablefem", formatter_class=argparse.RawDescriptionHelpFormatter,
                description="Bending moments at the anchors of vibrating cables: FEniCSx "
                            "extensible string + matched asymptotics.",
                epilog="Run 'cablefem keys' for every case-file key.")
    p.add_argument("--version", action="store_true", help="print the version and exit")
    sub = p.add_subparsers(dest="command", parser_class=_Parser)
    _add_run(sub, keys)
    _add_modes(sub, keys)
    _add_post(sub)
    _add_fatigue(sub)
    _add_compare(sub)
    _add_keys(sub)
    _add_batch(sub)
    return p


def _petsc_options(extra: list[str]) -> None:
    """Put ``-key value`` pairs left over by argparse into PETSc's options database."""
    from petsc4py import PETSc

    opts = PETSc.Options()
    i = 0
    while i < len(extra):
        tok = extra[i]
        if not tok.startswith("-") or len(tok) < 2:
            raise SystemExit(_input_error(f"unexpected argument '{tok}'"))
        key = tok.lstrip("-")
        val = None
        if i + 1 < len(extra) and not _is_option(extra[i + 1]):
            val = extra[i + 1]
            i += 1
        opts.setValue(key, val if val is not None else "")
        i += 1


def _is_option(tok: str) -> bool:
    if not tok.startswith("-"):
        return False
    try:
        float(tok)
        return False
    except ValueError:
        return True


def _input_error(msg: str) -> int:
    sys.stderr.write(f"cablefem: error: {msg}\n")
    return EXIT_INPUT


def _compare(args) -> int:
    """``cablefem compare``: no case file; rank 0 prints the table."""
    from mpi4py import MPI

    from cablefem.app.compare import compare_runs, format_table
    from cablefem.app.log import setup_logging

    setup_logging(logging.WARNING if args.quiet else logging.INFO)
    try:
        res = compare_runs(args.dir_a, args.dir_b, args.output)
    except ValueError as err:
        return _input_error(str(err))
    if not args.quiet and MPI.COMM_WORLD.rank == 0:
        print(format_table(res))
    return EXIT_OK


def main(argv: list[str] | None = None) -> int:
    """Entry point; an unexpected exception becomes one line (``CABLEFEM_DEBUG=1``: the
    traceback) and exit code 1.

    Args:
        argv: The arguments (default ``sys.argv[1:]``).

    Returns:
        The exit code (see the module docstring).
    """
    try:
        return _main(argv)
    except KeyboardInterrupt:  # outside a run's own handling (e.g. while reading input)
        sys.stderr.write("cablefem: interrupted (SIGINT)\n")
        return 128 + 2
    except SystemExit:
        raise
    except BrokenPipeError:  # the reader of stdout went away (`cablefem keys | head`)
        import os

        # Python would complain again when it flushes stdout at exit: point it at devnull
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_OK
    except Exception as err:  # noqa: BLE001 - the last guard of the command line
        import os

        if os.environ.get("CABLEFEM_DEBUG"):
            raise
        sys.stderr.write(f"cablefem: internal error: {type(err).__name__}: {err} (set "
                         "CABLEFEM_DEBUG=1 for the traceback, and please report it)\n")
        return EXIT_FAILED


def _main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    parser = _parser()
    args, extra = parser.parse_known_args(argv)
    if args.version:
        from cablefem import __version__

        print(f"cablefem {__version__}")
        return EXIT_OK
    if args.command is None:
        parser.print_help()
        return EXIT_INPUT
    if args.command == "keys":
        from cablefem.case import format_case_reference
        from cablefem.case.loadset import format_loadset_reference

        print(format_loadset_reference() if args.loadset else
              format_case_reference(network=args.network))
        return EXIT_OK
    if extra and args.command == "batch":
        return _input_error(f"unexpected arguments {extra}")
    if args.command == "batch":
        return _batch(args)
    if extra and args.command in ("post", "fatigue", "compare"):
        return _input_error(f"unexpected arguments {extra}")
    if args.command == "compare":
        return _compare(args)

    ck: dict = {}  # a restart's checkpoint
    if args.command == "run":
        ck, code = _run_args(args)
        if code is not None:
            return code
    case, code = _load(args, ck)
    if case is None:
        return code

    from cablefem.app.log import setup_logging

    setup_logging(logging.WARNING if args.quiet else logging.INFO)
    if args.command == "fatigue":
        return _fatigue(args, case)
    if args.command == "post":
        return _post(args, case)
    _petsc_options(extra)
    return _solve(args, case)


def _run_args(args) -> tuple[dict, int | None]:
    """``cablefem run``'s folders and, with ``--restart``, the options the checkpoint holds.

    Returns:
        The checkpoint (empty without ``--restart``) and an exit code if the arguments are
        refused, else None.
    """
    ck: dict = {}
    if args.restart is not None:
        from cablefem.io.checkpoint import read_checkpoint

        try:
            ck = read_checkpoint(args.restart)
        except ValueError as err:
            return ck, _input_error(str(err))
        if args.output is not None and args.output.resolve() != args.restart.resolve():
            return ck, _input_error("--output must be the --restart folder (or omitted)")
        from cablefem.io.checkpoint import run_status

        done = run_status(args.restart)
        if done.get("status") == "completed":
            return ck, _input_error(
                f"{args.restart}: the run is complete (t_end = {done.get('t_end')} s): "
                "nothing to restart; for a longer run, start a new one with a larger "
                "--t-end")
        args.output = args.restart
        args.case = args.case or Path(str(ck["case"]))
        for key, default in (("model", "string"), ("refine", 1.0),
                             ("outer_correction", "")):
            stored = type(default)(ck[key]) if key in ck else default
            given = getattr(args, key)
            if given is not None and given != stored and not (
                    key == "model" and given == "auto"):  # auto ran one of them
                return ck, _input_error(f"--{key} {given} differs from the checkpoint's "
                                        f"({stored}): restart with the same model")
            setattr(args, key, stored)
        if args.model != "beam":
            args.refine = None
        args.outer_correction = args.outer_correction or None
    if args.case is None or args.output is None:
        return ck, _input_error("give a case file and --output DIR, or --restart DIR")
    return ck, None


def _load(args, ck: dict):
    """Read the case file and check the options that depend on it.

    Returns:
        The case and None, or None and the exit code (the problem written to stderr).
    """
    from cablefem.case import CaseError, load_case

    case_path = args.case
    if getattr(args, "t_end", None) is not None and not args.t_end > 0:
        return None, _input_error(f"--t-end must be > 0 (s), got {args.t_end}")
    # the tables must reach the end of the run's dynamics, when it has any: --t-end, or
    # the checkpoint's end on a restart, else dynamics.t_end
    t_end = getattr(args, "t_end", None)
    if t_end is None and getattr(args, "restart", None) is not None and "t_stop" in ck:
        t_end = float(ck["t_stop"])
    try:
        case = load_case(case_path, t_end=t_end, dynamics=args.command == "run"
                         and not args.static_only)
    except CaseError as err:
        sys.stderr.write(str(err) + "\n")
        return None, EXIT_INPUT
    if getattr(args, "outer_correction", None) is not None:
        case.solver.outer_correction = args.outer_correction
    if getattr(args, "refine", None) is not None and not args.refine > 0:
        return None, _input_error(f"--refine must be > 0, got {args.refine}")
    if args.command == "run" and args.model is None:
        args.model = case.solver.model  # the case's route unless --model overrides it
    if getattr(args, "refine", None) is not None and getattr(args, "model", None) not in (
            "beam", "auto"):
        return None, _input_error("--refine applies to --model beam (or auto) only")
    if getattr(args, "n", None) is not None and args.n < 1:
        return None, _input_error(f"--n must be >= 1, got {args.n}")
    return case, None


def _fatigue(args, case) -> int:
    """``cablefem fatigue`` on a loaded case."""
    from cablefem.app.fatigue import run_fatigue
    from cablefem.case import CaseError
    from cablefem.io.outdir import output_lock

    if not (args.rundir / "anchors.csv").is_file():
        return _input_error(f"{args.rundir}: no anchors.csv there (not a run folder)")
    if case.fatigue is None:  # before the output folder is touched
        sys.stderr.write(f"{case.source}: fatigue: the case has no [fatigue] table "
                         "(detail_category, ...): see 'cablefem keys'\n")
        return EXIT_INPUT
    try:
        with output_lock(args.output or args.rundir):
            run_fatigue(case, args.rundir, args.output, window=args.window,
                        invalid=args.invalid)
    except CaseError as err:
        sys.stderr.write(str(err) + "\n")
        return EXIT_INPUT
    except ValueError as err:  # OutdirError included
        return _input_error(str(err))
    return EXIT_OK


def _post(args, case) -> int:
    """``cablefem post`` on a loaded case."""
    from cablefem.app.post import run_post
    from cablefem.io.outdir import output_lock

    try:
        with output_lock(args.output):
            run_post(case, args.forces, args.output, form=args.moment_form,
                     sign=args.sign)
    except ValueError as err:  # OutdirError included
        return _input_error(str(err))
    return EXIT_OK


def _solve(args, case) -> int:
    """``cablefem run`` and ``cablefem modes`` on as many of the launched ranks as pay off
    for the case's size (:func:`cablefem.app.ranks.run_sized`); every rank returns the
    code."""
    from cablefem.app.ranks import run_sized

    model = (args.model or "string") if args.command == "run" else "string"
    return run_sized(case, model, lambda comm, ranks: _solve_on(args, case, comm, ranks))


def _solve_on(args, case, comm, ranks: dict | None) -> int:
    """:func:`_solve` on ``comm`` (``ranks``: ``run_case``'s, when fewer run)."""
    from cablefem.app.run import RunError, RunInterrupted, run_case
    from cablefem.case import CaseError
    from cablefem.io.outdir import OutdirError
    from cablefem.statics import StaticError

    try:
        if args.command == "run":
            result = run_case(case, args.output, comm, t_end=args.t_end,
                              form=args.moment_form, dynamics=not args.static_only,
                              figures=not args.no_figures, progress=not args.quiet,
                              restart=args.restart is not None, model=args.model or "string",
                              refine=args.refine or 1.0, ranks=ranks)
        else:
            result = run_case(case, args.output, comm, modes=args.n, dynamics=False,
                              figures=False, progress=not args.quiet, model="string",
                              ranks=ranks)
    except CaseError as err:
        sys.stderr.write(str(err) + "\n")
        return EXIT_INPUT
    except OutdirError as err:
        return _input_error(str(err))
    except (RunError, StaticError) as err:
        sys.stderr.write(f"cablefem: run failed: {err}\n")
        return EXIT_FAILED
    except RunInterrupted as err:
        sys.stderr.write(f"cablefem: {err}\n")
        return 128 + (err.signal or 2)
    warned = result.summary.get("warnings") or []
    if warned and comm.rank == 0:  # once, as the log's warnings (rank 0)
        sys.stderr.write(f"cablefem: {len(warned)} warning(s), listed under 'warnings' in "
                         f"{Path(args.output) / 'summary.json'}\n")
    if warned and args.strict:
        return EXIT_WARNED
    return EXIT_OK


if __name__ == "__main__":
    raise SystemExit(main())
