"""The CLI contract of the Foundation issue: bench generate / check and their exit codes."""

import subprocess
import sys

from ehsa_opt.cli import main


def test_generate_then_check(tmp_path, capsys):
    out = tmp_path / "gen"
    assert main(["bench", "generate", str(out), "--seed", "5", "--effect", "backlash",
                 "--noise-force-N", "1.5"]) == 0
    assert len(list(out.glob("*.csv"))) == 21
    assert "backlash_gap_m" in (out / "truth.toml").read_text()
    assert main(["bench", "check", str(out)]) == 0
    assert "21 tests" in capsys.readouterr().out


def test_check_bad_exits_nonzero_with_message(tmp_path, capsys):
    out = tmp_path / "gen"
    assert main(["bench", "generate", str(out)]) == 0
    (out / "f2Hz_Re47.csv").write_text("time_s,displacement_m,force_N,voltage_V\n0,0,nan,0\n")
    assert main(["bench", "check", str(out)]) == 2
    err = capsys.readouterr().err
    assert "f2Hz_Re47.csv" in err and "row 2" in err and "force_N" in err


def test_generate_refuses_non_empty_dir_and_unknown_effect(tmp_path, capsys):
    out = tmp_path / "gen"
    out.mkdir()
    (out / "keep.txt").write_text("precious")
    assert main(["bench", "generate", str(out)]) == 2
    assert (out / "keep.txt").read_text() == "precious"
    assert main(["bench", "generate", str(tmp_path / "g2"), "--effect", "backlsh"]) == 2
    assert "did you mean 'backlash'" in capsys.readouterr().err


def test_console_entry_point_module(tmp_path):
    r = subprocess.run([sys.executable, "-m", "ehsa_opt", "bench", "check", str(tmp_path)],
                       capture_output=True, text=True)
    assert r.returncode == 2 and "bench.toml" in r.stderr


def test_interrupt_says_how_to_resume(monkeypatch, capsys, tmp_path):
    import ehsa_opt.pipeline.reproduce as rep

    def boom(**kwargs):
        raise KeyboardInterrupt
    monkeypatch.setattr(rep, "reproduce", boom)
    assert main(["reproduce", "--quick", "--out", str(tmp_path)]) == 130
    assert "run the same command again to resume" in capsys.readouterr().err
