"""Parameter studies under the realistic preset (Kinect sensor, wall check, execution error):
the Table 1 protocol (objects a-f, Setups 1-3), one factor at a time around the preset.

    python3 experiments/studies.py traced            # every study of a traced value, one process
    python3 experiments/studies.py window noise      # some studies
    python3 experiments/studies.py resolution        # a static value: compiles per resolution

Every traced study has 600 rounds per cell in all (100 per point for six points, 150 for four,
...), so all of them run the same compiled programs: they run in one process, and only the first
compiles. Every grid point has its own seed (seed + point index). Outputs: $OUT/NAME/ (default
results/studies/NAME/).
"""
import os
import sys

from graspjax.cli import main

ROUNDS = 600
TRACED = {  # name: the --grid arguments of one study
    "window": ["align.window_px=5,10,15,20,25,30"],
    "threshold": ["align.distance_threshold=0.05,0.1,0.2,0.3,0.5,1.0"],
    "reorientations": ["procedure.max_reorientations=0,1,2,3"],
    "friction": ["gripper.friction=0.3,0.5,0.7,0.9,1.0"],
    "noise": ["camera.noise_scale=0,0.5,1,2"],
    "execution": ["procedure.tcp_error:procedure.tilt_error_deg=0:0,0.001:0.5,0.002:1,0.004:2"],
    "centring": ["procedure.centre=true,false"],
}


def points(grid: list[str]) -> int:
    """Grid points of a one-factor study."""
    return len(grid[0].split("=", 1)[1].split(","))


def study_argv(name: str, out: str) -> list[str]:
    """The graspjax command line of one study."""
    common = ["--preset", "realistic", "--seed", "0", "--quiet", "--overwrite",
              "--out", os.path.join(out, name)]
    if name == "resolution":  # each resolution compiles its own programs: Setup 1 alone
        return ["sweep", "--setup", "1", "--objects", "abcdef", "--trials", "100", *common,
                "--grid", "camera.width:camera.height=80:60,160:120,320:240"]
    grid = TRACED[name]
    return ["sweep", "--table", "1", "--trials", str(ROUNDS // points(grid)), *common,
            *[a for g in grid for a in ("--grid", g)]]


if __name__ == "__main__":
    names = sys.argv[1:] or ["traced"]
    names = [n for name in names for n in (TRACED if name == "traced" else [name])]
    unknown = [n for n in names if n not in TRACED and n != "resolution"]
    if unknown:
        sys.exit(f"studies.py: unknown study {unknown[0]} (known: traced, resolution, "
                 f"{', '.join(TRACED)})")
    out = os.environ.get("OUT", "results/studies")
    for name in names:
        print(f"== study {name}", flush=True)
        if main(study_argv(name, out)) != 0:
            sys.exit(1)
