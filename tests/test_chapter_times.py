"""The CI summary's parser of per-chapter execution times (scripts/chapter_times.py)."""
import importlib.util
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "chapter_times.py"
spec = importlib.util.spec_from_file_location("chapter_times", SCRIPT)
chapter_times = importlib.util.module_from_spec(spec)
spec.loader.exec_module(chapter_times)


def test_times_are_read_with_the_chapter_from_either_source():
    log = [
        "\x1b[01mreading sources... \x1b[39;49;00m[ 20%] \x1b[35mnotebooks/01_toy_world\x1b[39;49;00m\n",
        "Executed notebook in 18.25 seconds [mystnb]\n",
        "reading sources... [ 40%] notebooks/02_diffusion\rreading sources... [ 60%] notebooks/03_data\n",
        "/repo/notebooks/03_data.ipynb: Executed notebook in 61.00 seconds [mystnb]\n",
        "build succeeded.\n",
    ]
    assert chapter_times.chapter_times(log) == [("notebooks/01_toy_world", 18.25), ("03_data", 61.0)]


def test_a_log_without_executions_is_reported(tmp_path, capsys):
    log = tmp_path / "book.log"
    log.write_text("reading sources... [100%] book/intro\nbuild succeeded.\n")
    assert chapter_times.main([str(log)]) == 1
    assert "no chapter execution times" in capsys.readouterr().out
