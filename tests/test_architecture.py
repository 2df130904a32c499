"""The package's layers (docs/architecture.md): no module imports one above it, the command line
is the only entry point, and every module has its place."""

import ast
import pathlib
import re

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent / "graspjax"

# Bottom to top. A module may import modules of its own layer or below, never above. A name
# ending in ".*" stands for every module of that package.
LAYERS = [
    ("foundations", ["version", "tree", "figures", "stats", "errors", "disk", "provenance", "geometry",
                     "camera", "codes", "schema", "privates"]),
    ("configuration", ["config"]),
    ("runtime", ["runtime", "runtime.*"]),
    ("one image, one world", ["perception", "perception.*", "sim", "sim.*", "synthetic",
                              "graspjax"]),
    ("the procedure; real-image inputs", ["procedure", "procedure.*", "imagefiles", "imagefiles.inputs",
                                          "imagefiles.resolution", "imagefiles.readers", "imagefiles.clouds",
                                          "imagefiles.bins"]),
    ("batches", ["batch", "batch.*", "imagefiles.batches", "imagefiles.records"]),
    ("studies, files, reports, benchmarks", ["planes", "saved_views", "figures.views", "figures.report",
                                             "figures.titles",
                                             "outputs", "report", "report.*", "reuse",
                                             "bench", "bench_finish", "bench_profile"]),
    ("workflows", ["experiment"]),
    ("entry point", ["cli", "parser", "arguments"]),
]


def _modules() -> dict[str, pathlib.Path]:
    """Every module of the package by dotted name under `graspjax` ("graspjax" for the root)."""
    out = {}
    for path in ROOT.rglob("*.py"):
        parts = path.relative_to(ROOT).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts) or "graspjax"] = path
    return out


def _layer(name: str) -> int:
    for i, (_, members) in enumerate(LAYERS):
        for member in members:
            if name == member or member.endswith(".*") and name.startswith(member[:-1]):
                return i
    raise KeyError(name)


def _imports(path: pathlib.Path) -> set[str]:
    """The graspjax modules a file imports (at the top or inside functions), by dotted name."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names = [f"{node.module}.{a.name}" for a in node.names]
            if not all(_dotted(name) in MODULES for name in names):  # names from the module
                names.append(node.module)
        else:
            continue
        found |= {_dotted(name) for name in names
                  if name == "graspjax" or name.startswith("graspjax.")}
    return found


def _dotted(name: str) -> str:
    """A module's name under the package ("graspjax" for the root)."""
    return name.removeprefix("graspjax.") if name != "graspjax" else "graspjax"


MODULES = _modules()


def test_every_module_has_a_layer():
    unplaced = []
    for name in MODULES:
        try:
            _layer(name)
        except KeyError:
            unplaced.append(name)
    assert not unplaced, f"modules without a layer in LAYERS: {unplaced}"


@pytest.mark.parametrize("name", sorted(MODULES))
def test_no_module_imports_one_above_it(name):
    mine = _layer(name)
    above = sorted(other for other in _imports(MODULES[name]) if other in MODULES
                   and _layer(other) > mine)
    assert not above, (f"{name} ({LAYERS[mine][0]}) imports {above} from a higher layer")


HELPERS = {"runtime.players", "runtime.tracer"}  # started by the run as `python -c "... main()"`


def test_the_entry_points_are_the_command_line_and_the_run_s_helpers():
    """`cli` is the user's entry point (its arguments are `parser`'s); the only others are the
    helper processes a run starts itself (`python -c "from graspjax.X import main; ..."`), and
    exactly those define main()."""
    started = set()
    for name, path in MODULES.items():
        text = path.read_text()
        assert "cli" not in _imports(path), f"{name} imports the command line"
        if name != "cli":
            assert '__name__ == "__main__"' not in text, name
        if name not in ("cli", "parser"):
            assert "argparse" not in text, name
        started |= set(re.findall(r"from graspjax\.([\w.]+) import main", text))
        defines_main = re.search(r"^def main\(", text, re.M) is not None
        assert defines_main == (name in HELPERS | {"cli"}), name
    assert started == HELPERS


def test_results_hold_results_not_code():
    """Measurement scripts and patches live in experiments/, the numbers in results/."""
    results = ROOT.parent / "results"
    code = sorted(str(p.relative_to(results)) for p in results.rglob("*")
                  if p.suffix in (".py", ".sh", ".patch"))
    assert code == []


def test_private_mjx_and_jax_names_are_reached_only_through_privates():
    """`privates.py` is the one module that names MJX's or JAX's private modules or MJX's
    private `_impl` fields: an upgrade of either is read there."""
    pattern = re.compile(r"\b(mujoco\.mjx\._src|jax\._src)\b|\._impl\b|[\"']_impl\.")
    offenders = [name for name, path in MODULES.items()
                 if name != "privates" and pattern.search(path.read_text())]
    assert offenders == []


def test_only_privates_swaps_stdout():
    """`sys.stdout` is swapped in one place (`privates.quiet_import`, one swap at a time): two
    swaps that overlap in two threads can lose every later print of the process."""
    offenders = [name for name, path in MODULES.items()
                 if name != "privates" and "redirect_stdout" in path.read_text()]
    assert offenders == []


def test_no_kernel_reads_the_backend_it_is_traced_for():
    """What depends on the device is a static setting chosen where a program is built
    (`config.for_device`), never read from JAX's backend while a kernel is traced: one image's
    and one world's modules, the procedure and the pytree helpers never ask for it."""
    kernels = [name for name in MODULES if name.split(".")[0] in
               ("perception", "sim", "procedure", "synthetic", "tree", "geometry", "camera")]
    assert len(kernels) > 20
    offenders = [name for name in kernels if "default_backend" in MODULES[name].read_text()]
    assert offenders == []


def test_a_program_s_device_chooses_how_placements_are_checked():
    """`for_device`: a CPU's programs check placements in chunks (as set), any other device's
    all at once; a setting of False stays False everywhere. Only `graspjax detect`'s programs
    on a device other than a CPU unroll the searches' loops (a simulated run's do not)."""
    import dataclasses

    from graspjax.config import Config, for_device

    config = Config()
    assert config.detect.checks_in_chunks and for_device(config, "cpu") is config
    assert not for_device(config, "gpu").detect.checks_in_chunks
    assert for_device(config, "gpu").align == config.align  # nothing else changes
    assert not for_device(config, "gpu").detect.unrolled_loops
    assert for_device(config, "gpu", images=True).detect.unrolled_loops
    assert for_device(config, "cpu", images=True) is config
    off = dataclasses.replace(config, detect=dataclasses.replace(config.detect,
                                                                 checks_in_chunks=False))
    assert not for_device(off, "cpu").detect.checks_in_chunks


def test_every_private_name_resolves_in_the_installed_versions():
    """Each name `privates.py` lists is found where it says, in the JAX and MJX installed (an
    upgrade that moves one fails here, not in a run)."""
    from graspjax import privates

    missing = []
    for name in privates._NAMES:
        try:
            getattr(privates, name)
        except (ImportError, AttributeError) as error:
            missing.append(f"{name}: {error}")
    assert missing == []


def test_the_physics_rework_has_one_door():
    """Outside `sim.physics`, modules import the package's public names only, never its parts."""
    inside = {name for name in MODULES if name.startswith("sim.physics.")}
    offenders = sorted((name, sorted(_imports(path) & inside)) for name, path in MODULES.items()
                       if not name.startswith("sim.physics") and _imports(path) & inside)
    assert offenders == []


def test_no_circle_of_imports():
    """No module reaches itself through the modules it imports (a package counts as its
    `__init__`)."""
    graph = {name: {other for other in _imports(path) if other in MODULES and other != name}
             for name, path in MODULES.items()}
    done, path = set(), []

    def visit(name):
        if name in path:
            raise AssertionError(" -> ".join(path[path.index(name):] + [name]))
        if name in done:
            return
        path.append(name)
        for other in sorted(graph[name]):
            visit(other)
        path.pop()
        done.add(name)

    for name in sorted(graph):
        visit(name)


def test_no_module_but_the_configuration_is_longer_than_450_lines():
    """A module a reader takes in whole; `config.py` is a list of documented fields."""
    long = {name: len(path.read_text().splitlines()) for name, path in MODULES.items()
            if name != "config" and len(path.read_text().splitlines()) > 450}
    assert long == {}


def test_no_function_but_the_argument_parser_is_longer_than_80_lines():
    """A function a reader holds in mind at once: a longer one splits into named steps (a
    kernel's into helpers, a loop's state into a typed carry, as `perception/target_loop.py`).
    The argument parser is a list of `add_argument` calls."""
    long = []
    for name, path in MODULES.items():
        for node in ast.walk(ast.parse(path.read_text())):
            if (isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef)
                    and node.end_lineno - node.lineno + 1 > 80
                    and (name, node.name) != ("parser", "build_parser")):
                long.append(f"{name}.{node.name}: {node.end_lineno - node.lineno + 1} lines")
    assert long == []


def test_the_command_line_s_dispatch_is_at_most_350_lines():
    """`cli.py` dispatches and prints; the subcommands' arguments are `parser.py`'s and their
    checks `arguments.py`'s."""
    assert len((ROOT / "cli.py").read_text().splitlines()) <= 350


EXPERIMENTS = ROOT.parent / "experiments"


def test_experiment_files_name_what_exists():
    """Every experiment file parses (`bash -n` for scripts), imports only public names that the
    package has, names only experiment files that exist, and is listed in experiments/README.md."""
    import importlib
    import importlib.util
    import subprocess

    listed = (EXPERIMENTS / "README.md").read_text()
    files = sorted(p for p in EXPERIMENTS.iterdir() if p.suffix in (".py", ".sh"))
    assert files
    problems = []
    for path in files:
        text = path.read_text()
        if f"`{path.name}" not in listed:
            problems.append(f"{path.name}: not in experiments/README.md")
        for named in set(re.findall(r"experiments/([\w.-]+\.(?:py|sh))", text)):
            if not (EXPERIMENTS / named).exists():
                problems.append(f"{path.name}: names experiments/{named}, which is not there")
        if path.suffix == ".sh":
            check = subprocess.run(["bash", "-n", str(path)], capture_output=True, text=True)
            if check.returncode:
                problems.append(f"{path.name}: {check.stderr.strip()}")
            continue
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                top = node.module.split(".")[0]
                if top == "graspjax":
                    module = importlib.import_module(node.module)
                    for alias in node.names:
                        if alias.name.startswith("_") or not hasattr(module, alias.name):
                            problems.append(f"{path.name}: {node.module}.{alias.name}")
                elif not (EXPERIMENTS / f"{top}.py").exists() and importlib.util.find_spec(top) is None:
                    problems.append(f"{path.name}: imports {node.module}, which is not there")
    assert problems == []
