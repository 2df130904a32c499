"""`bench_profile`: device time per compiled operation, named by its source line."""

import pathlib

import jax
import jax.numpy as jnp
import pytest

import graspjax
from graspjax.bench_profile import FirstRound, attributed, device_ops, op_sources, summary
from graspjax.schema import PROFILE_COLUMNS

HLO = """HloModule jit_step, entry_computation_layout={(f32[8]{0})->f32[8]{0}}

FileNames
1 "/site/mujoco/mjx/_src/smooth.py"
2 "/site/graspjax/perception/grasp.py"

FunctionNames
1 "kinematics"
2 "detect_grasp"

FileLocations
1 {file_name_id=1 function_name_id=1 line=40 end_line=40 column=2 end_column=9}
2 {file_name_id=2 function_name_id=2 line=77 end_line=77 column=4 end_column=20}

StackFrames
1 {file_location_id=1 parent_frame_id=1}
2 {file_location_id=2 parent_frame_id=1}

%fc (param_0: f32[8]) -> f32[8] {
  %param_0 = f32[8]{0} parameter(0)
  ROOT %sine.1 = f32[8]{0} sine(%param_0), metadata={op_name="jit(step)/sin" stack_frame_id=1}
}

ENTRY %main.3 (x: f32[8]) -> f32[8] {
  %x = f32[8]{0} parameter(0)
  %loop_fusion = f32[8]{0} fusion(%x), kind=kLoop, calls=%fc, metadata={op_name="sin" stack_frame_id=1}
  ROOT %cosine.2 = f32[8]{0} cosine(%loop_fusion), metadata={source_file="/elsewhere/old.py" source_line=9}
  %copy.1 = f32[8]{0} copy(%x)
  %negate.4 = f32[8]{0} negate(%x), metadata={op_name="jit(step)/neg" stack_frame_id=2}
}
"""


def test_op_sources_reads_stack_frames_and_source_lines():
    sources = op_sources(HLO)
    assert sources["loop_fusion"] == ("/site/mujoco/mjx/_src/smooth.py", "kinematics", 40)
    assert sources["sine.1"] == sources["loop_fusion"]
    # a program compiled where graspjax lay elsewhere (loaded from the compilation cache)
    assert sources["negate.4"] == ("graspjax/perception/grasp.py", "detect_grasp", 77)
    assert sources["cosine.2"] == ("/elsewhere/old.py", "", 9)
    assert "copy.1" not in sources  # no metadata
    package = str(pathlib.Path(graspjax.__file__).parent)  # wherever it is installed
    mine = op_sources(HLO.replace("/site/graspjax", package))
    assert mine["negate.4"] == ("graspjax/perception/grasp.py", "detect_grasp", 77)
    other_host = op_sources(HLO.replace("/site/", "/opt/venv/lib/python3.12/site-packages/"))
    assert other_host["loop_fusion"] == ("mujoco/mjx/_src/smooth.py", "kinematics", 40)


def _heavy(x):
    return jnp.tanh(x @ x.T @ x)


def _light(x):
    return x[:4, :4] + 1.0


@pytest.fixture(scope="module")
def profiled(tmp_path_factory):
    step = jax.jit(lambda x: (_heavy(x), _light(x)))
    x = jnp.linspace(0.0, 1.0, 640 * 640, dtype=jnp.float32).reshape(640, 640)
    jax.block_until_ready(step(x))
    folder = tmp_path_factory.mktemp("trace")
    with jax.profiler.trace(str(folder)):
        for _ in range(3):
            jax.block_until_ready(step(x))
    return device_ops(folder), step.lower(x).compile().as_text()


def test_device_time_goes_to_the_line_that_traced_it(profiled):
    """Two 640 x 640 matrix products against a 4 x 4 add: the product's function takes nearly
    all of the device time, and every kernel of it was called once per call of the program."""
    ops, text = profiled
    kernels = attributed(ops, [text])
    assert list(kernels.columns) == list(PROFILE_COLUMNS)
    by_function = kernels.groupby("function")["seconds"].sum()
    assert by_function["_heavy"] > 0.9 * kernels["seconds"].sum()
    assert by_function.get("_light", 0.0) < 0.05 * by_function["_heavy"]
    heavy = kernels[kernels["function"] == "_heavy"]
    assert all(f.endswith("test_bench_profile.py") for f in heavy["file"])  # sys.path-relative
    assert (heavy["calls"] % 3 == 0).all()
    text_out = summary(kernels, traced_s=1.0)
    assert "_heavy" in text_out.splitlines()[text_out.splitlines().index("by function:") + 1]


def test_the_first_round_is_traced_from_the_last_compile_to_the_first_attempt(tmp_path):
    """`FirstRound` starts the trace when nothing is left compiling and stops it at the first
    attempt's end: an operation run before it, inside it and after it, only the middle one is
    in the trace."""
    def before(x):
        return jnp.sin(x)

    def inside(x):
        return jnp.cos(x)

    def after(x):
        return jnp.tanh(x)

    window = FirstRound(tmp_path / "trace")
    before, inside, after = jax.jit(before), jax.jit(inside), jax.jit(after)
    x = jnp.ones((256, 256))
    for f in (before, inside, after):
        jax.block_until_ready(f(x))  # compiled outside the trace
    window.status("compiling abcdef (Setup 2, 3)")
    jax.block_until_ready(before(x))
    window.status("")
    jax.block_until_ready(inside(x))
    window.attempted(2048)
    jax.block_until_ready(after(x))
    window.attempted(2048)
    window.close()  # a second stop is nothing
    assert window.seconds > 0
    assert set(device_ops(tmp_path / "trace")["module"]) == {"jit_inside"}


def test_an_operation_around_others_counts_only_through_them():
    """A CPU while loop's event holds its body's events on the same line: only the innermost
    count, also where the first child starts with its parent; an event naming no HLO
    operation (a thread pool's) counts nothing."""
    from types import SimpleNamespace

    from graspjax.bench_profile import _leaf_ops

    def event(start, duration, op):
        stats = [("hlo_module", "jit_f"), ("hlo_op", op)] if op else [("other", 1)]
        return SimpleNamespace(start_ns=start, duration_ns=duration, stats=stats, name=op or "pool")

    line = SimpleNamespace(events=[event(100, 30, "body.2"), event(100, 100, "while"),
                                   event(140, 50, "body.3"), event(0, 500, None),
                                   event(300, 10, "after")])
    got = {op: seconds for _, op, _, seconds in _leaf_ops(line)}
    assert got == pytest.approx({"body.2": 30e-9, "body.3": 50e-9, "after": 10e-9})


def test_a_folder_without_a_trace_is_refused(tmp_path):
    with pytest.raises(FileNotFoundError, match="no \\*.xplane.pb"):
        device_ops(tmp_path)
