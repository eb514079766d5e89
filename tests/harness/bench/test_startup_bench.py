"""The start-up bench (section 8 of ``spurdiff bench``) finds the plain C FMU it compares against:
after the harness moved into packages it looked for tests/broken_fmus/ one folder too high and
printed "not measured" instead of the section, silently."""
from __future__ import annotations

import shutil

import pytest

from harness.cli.tools import startup_bench
from harness.measure.bench import startup


def test_the_c_fmu_source_is_found_in_the_checkout():
    assert startup.CHK_BUILD.is_file(), startup.CHK_BUILD
    assert startup.HOST_SOURCE.is_file(), startup.HOST_SOURCE


@pytest.mark.skipif(shutil.which("gcc") is None, reason="no C compiler (gcc) to build the kit's C FMU")
def test_the_c_fmu_builds():
    fmu = startup.c_fmu()
    assert fmu is not None and fmu.is_file() and fmu.suffix == ".fmu"


def test_an_earlier_build_that_is_not_a_file_is_refused_with_one_line(tmp_path, capsys):
    with pytest.raises(SystemExit) as e:
        startup_bench.main(["3", "--against", str(tmp_path / "missing.fmu")])
    assert e.value.code != 0
    assert f"--against {tmp_path / 'missing.fmu'}: no such FMU file" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        startup_bench.main(["0"])
    assert "runs 0: allowed 1 or more" in capsys.readouterr().err


def test_the_cached_start_measure_sets_the_parameter_and_fills_its_own_cache(differential_fmu, tmp_path):
    """The bench's 'a parameter set, 3rd start on' rows: its fresh fmpy hosts set startup.SETTING, the
    second keeps the native start of it in the bench's own folder, the third starts from it."""
    import zipfile

    unz = tmp_path / "x"
    zipfile.ZipFile(differential_fmu).extractall(unz)
    env = {"SPURDIFF_FMU_START_CACHE_DIR": str(tmp_path / "starts")}
    for own in (False, True, True):
        assert startup.init_time(differential_fmu, unz, own, env, startup.SETTING) > 0
    assert len(list((tmp_path / "starts").glob("*.bin"))) == 1
    assert len(list((tmp_path / "starts").glob("*.seen"))) == 1


def test_the_widened_vectors_repeat_the_value_references_in_order():
    assert startup._widened([3, 7], 5) == [3, 7, 3, 7, 3]
    assert startup._widened([4], 3) == [4, 4, 4]


@pytest.mark.skipif(shutil.which("gcc") is None, reason="no C compiler (gcc) to build the kit's C FMU")
def test_the_c_fmu_steps_asked_for_as_many_values_as_ours(tmp_path, monkeypatch):
    """The per-step row at the same width: ChkC's one input set and two outputs read as often as
    SpurDifferential's (every call answered fmi2OK: fmpy raises otherwise), the vectors passed being
    the widened ones."""
    import zipfile

    from fmpy.fmi2 import FMU2Slave

    fmu = startup.c_fmu()
    unz = tmp_path / "c"
    zipfile.ZipFile(fmu).extractall(unz)
    seen = []
    real_set = FMU2Slave.setReal
    monkeypatch.setattr(FMU2Slave, "setReal", lambda self, vr, v: (seen.append(len(vr)), real_set(self, vr, v))[1])
    fmpy_us, ctypes_us = startup.per_step(fmu, unz, n=50, rounds=2, width=(20, 33))
    assert fmpy_us > 0 and ctypes_us > 0
    assert set(seen) == {20}


def test_the_long_run_measure_steps_then_starts_the_python(differential_fmu, tmp_path):
    """The 'native run' rows: a fresh fmpy host steps the native start, then its FMU state call starts
    the model's Python (it takes measurable time: the Python starts), and the host's memory did not
    grow by 1 MB over 3,000 steps; a folder without the FMU is a RuntimeError naming it."""
    import zipfile

    unz = tmp_path / "x"
    zipfile.ZipFile(differential_fmu).extractall(unz)
    grown, took = startup.long_run(differential_fmu, unz, 3000)
    assert took > 1e-3 and grown < 1e6
    with pytest.raises(RuntimeError, match=differential_fmu.name):
        startup.long_run(differential_fmu, tmp_path / "nothing", 10)
