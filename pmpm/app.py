"""From command-line arguments to a finished run: load and check the case, prepare the
output directory, build or restore the state, compile, run."""
import os
import sys

from .output_dir import (LOCK_NAME, acquire_lock, force_problem, release_lock,
                         replace_run_files)
from .solver.errors import SetupError


class InputError(Exception):
    """Bad input: ``problems`` holds one line per problem, each naming its key."""

    def __init__(self, problems):
        self.problems = list(problems)
        super().__init__("\n".join(self.problems))



def run_case(world, args, loaded=None):
    """Run the case of ``args`` on ``world`` (``loaded``: what :func:`load_checked_case`
    returned for it, if already called); returns the summary.json path."""
    config, case_text, case = loaded or load_checked_case(args.case, args.overrides)
    if world.is_root:
        warn_about_case(case, args.case)
    out = args.out or os.path.join("results", _stem(args.case))
    prepare_output(world, out, args.force, args.restart, case_path=args.case)
    try:
        return run_locked(world, args, out, config, case_text, case)
    finally:
        if world.is_root:
            release_lock(out)


def check_case(world, args, loaded=None):
    """``--check``: validate the case, lay its bodies out and decompose it as a run would,
    and return the lines that say what the run would be (particles and elements, steps,
    output, memory, the output directory), without compiling a kernel or touching the
    output directory. Bad input raises InputError as a run would."""
    from .case import fill_body
    from .case.size import case_estimate, needed_bytes, _bytes
    from .solver.estimate import check_size, initial_speed
    from .solver.simulation import Simulation
    config, _, case = loaded or load_checked_case(args.case, args.overrides)
    if world.is_root:
        warn_about_case(case, args.case)
    case_dir = os.path.dirname(os.path.abspath(args.case))
    out = args.out or os.path.join("results", _stem(args.case))
    layout = _set_up(Simulation.lay_out, world, config, case_dir, fill_body)
    filled, meshes = layout[1], layout[4]
    size = _set_up(check_size, world, config, sum(len(v) for _, v in filled),
                   lambda: initial_speed(config, filled, meshes), _existing_folder(out),
                   0.0, True, mesh_counts(meshes))
    particles, nodes = case_estimate(dict(enumerate(case["bodies"])), case["grid"], case_dir)
    lines = [f"pmpm: check: {args.case} is valid"]
    if size:
        lines.append(size)
    if meshes:
        elements = mesh_counts(meshes)[0]
        lines.append(f"pmpm: {elements:,} elements in {len(meshes)} FEM "
                     f"bod{'y' if len(meshes) == 1 else 'ies'}")
    memory = needed_bytes(float(sum(particles.values())), nodes, world.size)
    lines.append(f"pmpm: memory about {_bytes(memory)} in all on {world.size} "
                 f"rank{'s' if world.size > 1 else ''} (the estimate that "
                 f"decomposition.memory_limit_gb is checked against)")
    lines.append(f"pmpm: output to {out}" + _output_state(out))
    return lines


def mesh_counts(meshes):
    """(elements, nodes) of the FEM bodies' meshes ({name: mesh})."""
    return (sum(len(m.hexes) for m in meshes.values()),
            sum(len(m.points) for m in meshes.values()))


def group_counts(groups):
    """(elements, nodes) of a checkpoint's FEM groups ({} without FEM bodies)."""
    return tuple(len(next(iter(groups[name].values()), ())) if groups.get(name) else 0
                 for name in ("elements", "nodes"))


def _existing_folder(path):
    """``path`` or its nearest existing parent (where the free space is measured)."""
    path = os.path.abspath(path)
    while not os.path.isdir(path) and os.path.dirname(path) != path:
        path = os.path.dirname(path)
    return path


def _output_state(out):
    """What a run would need to write into ``out``: a note when it holds results."""
    if os.path.isdir(out) and [n for n in os.listdir(out) if n != LOCK_NAME]:
        return " (not empty: the run needs --force to replace it or --restart to continue)"
    return ""


def run_locked(world, args, out, config, case_text, case):
    """The run proper, while rank 0 holds the lock on ``out``."""
    checkpoint = None
    if args.restart:
        checkpoint = choose_checkpoint(world, out)
        case_text = check_restart_case(world, checkpoint, case, case_text)
    from .kernels.shape import SHAPE_CODES
    from .kernels.warmup import kernels_of, warm_up
    from .solver.memory import (current_rss_bytes, return_freed_memory_to_os,
                                threshold_for_fe_nodes)
    from .solver.progress import SlowNotice
    from .solver.run import Runner
    quiet_numba_pedantry()
    return_freed_memory_to_os()
    before_setup = current_rss_bytes()
    setup = begin_set_up(world, config, args, checkpoint, out)
    before_compile = current_rss_bytes()
    with SlowNotice(f"compiling the {config.grid.shape_functions} kernels (the first run "
                    f"after an install or an edit: a few minutes; later runs load them)",
                    world.is_root and not args.quiet and config.output.progress):
        compile_s = world.max(warm_up(SHAPE_CODES[config.grid.shape_functions],
                                      **kernels_of(config)))
    baseline = before_setup + current_rss_bytes() - before_compile
    sim, restart, size = setup()
    del setup      # its closure holds the whole meshes and every body's points (or the
    #                checkpoint's FEM groups, whole): no rank keeps them for the run
    if sim.elements:
        return_freed_memory_to_os(threshold_for_fe_nodes(len(sim.elements.x)))
    if size and not args.quiet:
        print(size, flush=True)
    runner = _set_up(lambda: Runner(sim, out, case_text, progress=not args.quiet,
                                    restart=restart, case=case))    # probes check theirs
    runner.run(compile_s=compile_s, baseline_rss=baseline)
    return os.path.join(out, "summary.json")


def quiet_numba_pedantry():
    """Silence Numba's NumbaIRAssumptionWarning: an internal self-check of its SSA pass
    ("variable ... is not in scope", "please report") that the exact sums' inlined
    accumulator sets off while a cold cache compiles; it changes no code, and a user
    reading a run's output has nothing to do about it."""
    import warnings
    from numba.core.errors import NumbaIRAssumptionWarning
    warnings.filterwarnings("ignore", category=NumbaIRAssumptionWarning)


def load_checked_case(path, overrides):
    """The case's CaseConfig, its text (with the overrides) and the validated case dict,
    or InputError."""
    from .case import CaseConfig, CaseError, load_case
    try:
        case = load_case(path, overrides)
    except CaseError as err:
        raise InputError(err.problems) from None
    with open(path, encoding="utf-8") as f:
        text = f.read()
    if overrides:
        text += "\n# --set " + " --set ".join(overrides) + "\n"
    return CaseConfig.from_case(case), text, case


def warn_about_case(case, path):
    """Rank 0: one line for each thing the case may do badly though it is valid."""
    from .case.fem import grid_coupling_warnings, surface_contact_step_warnings
    lines = grid_coupling_warnings(case, os.path.dirname(os.path.abspath(path)))
    for line in lines + surface_contact_step_warnings(case):
        sys.stderr.write(f"pmpm: warning: {line}\n")
    sys.stderr.flush()


def prepare_output(world, out, force, restart, case_path=None):
    """Lock the output directory and refuse to overwrite results unless asked; decided
    on rank 0 for every rank. On success rank 0 holds ``out/pmpm.lock`` (release it with
    ``output_dir.release_lock``).

    Collective. The first barrier makes every rank finish reading its input (the case
    file) before rank 0 may delete anything; ``--force`` deletes only a run's files."""
    world.barrier()
    problem = None
    if world.is_root:
        problem = _lock_and_check_output(out, force, restart, case_path)
    problem = world.bcast(problem)
    if problem:
        raise InputError([problem])
    world.barrier()


def _lock_and_check_output(out, force, restart, case_path=None):
    """Rank 0: take the lock on ``out`` (created, when absent and not a restart), then
    check it; returns the problem line (the lock released) or None (the lock held)."""
    if os.path.exists(out) and not os.path.isdir(out):
        return f"--out: '{out}' exists and is not a directory"
    if restart and not os.path.isdir(out):
        return f"--restart: no checkpoint in '{out}'"
    try:
        os.makedirs(out, exist_ok=True)
    except OSError as err:
        return f"--out: cannot prepare output directory '{out}': {err.strerror or err}"
    problem, warning = acquire_lock(out)
    if problem:
        return problem
    if warning:
        sys.stderr.write(f"pmpm: warning: {warning}\n")
        sys.stderr.flush()
    problem = _check_output(out, force, restart, case_path)
    if problem:
        release_lock(out)
    return problem


def _check_output(out, force, restart, case_path=None):
    """The problem with the locked directory ``out`` (its lock aside), or None."""
    try:
        names = [name for name in os.listdir(out) if name != LOCK_NAME]
    except OSError as err:
        return f"--out: cannot read output directory '{out}': {err.strerror or err}"
    if restart:
        from .io import latest_checkpoint
        if not names or latest_checkpoint(out) is None:
            return f"--restart: no checkpoint in '{out}'"
        return None
    if names and not force:
        return (f"--out: output directory '{out}' exists and is not empty; "
                f"use --force to overwrite it or --restart to continue it")
    if names:
        problem = force_problem(out, case_path, names)
        if problem:
            return problem
    try:
        if names:
            replaced = replace_run_files(out, names)
            print(f"pmpm: --force: replacing {', '.join(replaced)} in {out}")
            sys.stdout.flush()
    except OSError as err:
        return f"--out: cannot prepare output directory '{out}': {err.strerror or err}"
    return None


def choose_checkpoint(world, out):
    """The newest checkpoint in ``out`` that can be read (collective; rank 0 decides).

    A newer one that cannot (truncated, overwritten) is passed over with a one-line
    warning naming it; none readable is an InputError."""
    chosen, bad = None, []
    if world.is_root:
        from .io.checkpoint import checkpoint_problem, list_checkpoints
        found = [path for _, path in reversed(list_checkpoints(out))]
        for k, path in enumerate(found):
            problem = checkpoint_problem(path)
            if problem is None:
                chosen = path
                break
            bad.append(f"{os.path.basename(path)}: {problem}")
            if k + 1 < len(found):
                sys.stderr.write(f"pmpm: warning: --restart: checkpoint '{path}' cannot be "
                                 f"read ({problem}); trying the one before it\n")
                sys.stderr.flush()
    chosen, bad = world.bcast((chosen, bad))
    if chosen is None:
        raise InputError([f"--restart: no readable checkpoint in '{out}' ("
                          + "; ".join(bad) + ")"])
    return chosen


def check_restart_case(world, checkpoint, case, case_text):
    """The case text a restarted run keeps: the checkpoint's (its run's original text),
    with a comment listing the changes ``--restart`` accepts. A change to any other key
    is an InputError naming each (collective; rank 0 reads the checkpoint)."""
    result = None
    if world.is_root:
        from .case.compare import may_change_text, restart_changes
        from .io import read_checkpoint_case
        stored = read_checkpoint_case(checkpoint)
        if stored is None:              # a checkpoint from before they kept their case
            result = ([], case_text)
        else:
            refused, allowed = restart_changes(stored["case"], case)
            text = stored["text"]
            if allowed:
                text = text.rstrip("\n") + "\n# --restart from " + os.path.basename(
                    checkpoint) + ": " + "; ".join(f"{path}: {change}"
                                                   for path, change in allowed) + "\n"
            result = ([f"{path}: changed since the checkpoint ({change}); --restart may "
                       f"change only {may_change_text()}" for path, change in refused], text)
    problems, text = world.bcast(result)
    if problems:
        raise InputError(problems)
    return text


def begin_set_up(world, config, args, checkpoint, out):
    """What can be checked before the kernels compile (the checkpoint, the bodies'
    positions, the slab decomposition, the run's size against time.max_steps and the
    free disk space), so that a bad input fails in a second;
    returns a function that finishes the set-up and gives (simulation, checkpoint
    scalars or None, the line that tells the run's estimated size on rank 0)."""
    from .case import fill_body
    from .solver.simulation import Simulation
    from .solver.estimate import check_size, initial_speed
    if args.restart:
        scalars, columns, groups = read_checkpoint(world, checkpoint, config)
        end = float(config.time.end)
        if scalars["time"] > end * (1 + 1e-12):
            raise InputError([f"time.end: {end:g} is before the checkpoint's time "
                              f"{scalars['time']:g}; --set a later time.end to continue"])
        size = _set_up(check_size, world, config, world.sum(len(columns["x"])),
                       lambda: scalars["fastest"], out, scalars["time"], False,
                       group_counts(groups))
        return lambda: (_set_up(Simulation.from_checkpoint, world, config, scalars, columns,
                                groups),
                        scalars, size)
    case_dir = os.path.dirname(os.path.abspath(args.case))
    layout = _set_up(Simulation.lay_out, world, config, case_dir, fill_body)
    filled = layout[1]
    size = _set_up(check_size, world, config, sum(len(v) for _, v in filled),
                   lambda: initial_speed(config, filled, layout[4]), out, 0.0, True,
                   mesh_counts(layout[4]))
    return lambda: (_set_up(Simulation.from_layout, world, config, layout), None, size)


def _set_up(build, *args):
    """``build(*args)``, its SetupError turned into InputError."""
    try:
        return build(*args)
    except SetupError as err:
        raise InputError(err.problems) from None


def read_checkpoint(world, path, config):
    """Scalars, this rank's share of the particles of the checkpoint at ``path`` and,
    when the case has FEM bodies, its elements and nodes whole (collective). A failure
    on any rank stops every rank with the lowest failing rank's line (a rank that alone
    stopped would leave the others waiting in the set-up's collectives)."""
    from .io import load_checkpoint
    problem = result = None
    try:
        scalars, columns = load_checkpoint(path, world.raw)
        groups, problem = read_fem_groups(path, config)
        result = scalars, columns, groups
    except (OSError, KeyError, ValueError) as err:
        problem = f"--restart: cannot read checkpoint '{path}': {err}"
    problem = world.first_message(problem)
    if problem:
        raise InputError([problem])
    return result


def read_fem_groups(path, config):
    """({name: rows} of the elements and nodes of the checkpoint, when the case has FEM
    bodies, or {}; the problem line when it holds none). Not collective."""
    from .io import load_group
    if not any(body.is_fem for body in config.bodies):
        return {}, None
    groups = {name: load_group(path, name) for name in ("elements", "nodes")}
    if any(group is None for group in groups.values()):
        return groups, (f"--restart: checkpoint '{path}' holds no FEM bodies, which the "
                        f"case has")
    return groups, None


def _stem(path):
    return os.path.splitext(os.path.basename(path))[0]
