"""Benchmark records (graspjax.bench): the fields `schema.BENCH_FIELDS` names, in its order, and
the printed summary; speed is never asserted."""

import pytest

from graspjax import bench
from graspjax.provenance import provenance
from graspjax.schema import BENCH_FIELDS, PROVENANCE_FIELDS


def test_provenance_has_the_schema_s_fields():
    assert tuple(provenance()) == PROVENANCE_FIELDS


def test_a_record_follows_the_schema_and_refuses_other_fields():
    values = {name: 0 for name in (*BENCH_FIELDS["pipeline"], *PROVENANCE_FIELDS)}
    record = bench.bench_record("pipeline", dict(reversed(values.items())))
    assert tuple(record) == (*BENCH_FIELDS["pipeline"], *PROVENANCE_FIELDS)
    with pytest.raises(AssertionError, match="attempts_per_s"):
        bench.bench_record("pipeline", {k: v for k, v in values.items() if k != "attempts_per_s"})


def test_a_tiny_perception_benchmark_writes_its_record():
    record = bench.perception_benchmark(batch=2, width=32, height=24, repeats=1, unique=2,
                                        progress=lambda m: None)
    assert tuple(record) == (*BENCH_FIELDS["perception"], *PROVENANCE_FIELDS)
    assert record["batch"] == 2 and record["detect+align_images_per_s"] > 0
    assert "single image (detect+align)" in bench.format_perception(record)


def test_a_tiny_detect_benchmark_writes_its_record_and_its_profile(tmp_path):
    """Two real-looking 640 x 480 images, in a batch of two and one at a time, with the default
    settings: the programs test_image_batches, test_jaws and test_cli's folder run
    (`detect_batch` of two images, `detect_single`), so the suite compiles them once.
    Profiled, the call `graspjax detect` makes on a CPU (one image) spends its device time in
    the lines of graspjax's perception that traced it."""
    import pandas as pd

    record = bench.detect_benchmark(batch=2, width=640, height=480, repeats=1, unique=2,
                                    progress=lambda m: None, profile=str(tmp_path))
    assert tuple(record) == (*BENCH_FIELDS["detect"], *PROVENANCE_FIELDS)
    assert record["images_per_s"] > 0 and 0 <= record["grasp_found_fraction"] <= 1
    assert "images/s" in bench.format_detect(record)
    assert record["profiled_call"] == "single"  # a CPU's `graspjax detect` calls one image
    assert "one single call profiled" in bench.format_detect(record)
    kernels = pd.read_csv(tmp_path / "kernels.csv")
    by_file = kernels.groupby(kernels["file"].fillna(""))["seconds"].sum()
    assert by_file[by_file.index.str.startswith("graspjax/perception/")].sum() > 0.5 * by_file.sum()
    assert record["profile_summary"] in bench.format_detect(record)


def test_a_small_finish_benchmark_times_the_rows_it_asked_for():
    """The committed 10-trial run's 240 rows, repeated to 1,000 (five copies), through a run
    folder's finish and report."""
    from pathlib import Path

    import pandas as pd

    from graspjax.bench_finish import finish_benchmark, format_finish

    source = Path(__file__).parents[1] / "results" / "paper_cpu_10"
    chunks = pd.read_csv(source / "attempts.csv")["chunk"].nunique()
    record = finish_benchmark(str(source), rows=1000, progress=lambda m: None)
    assert tuple(record) == (*BENCH_FIELDS["finish"], *PROVENANCE_FIELDS)
    assert record["rows"] == 1200 and record["chunks"] == 5 * chunks
    assert record["after_last_chunk_s"] == pytest.approx(record["files_s"] + record["report_s"])
    assert f"1,200 rows in {5 * chunks} chunks" in format_finish(record)
