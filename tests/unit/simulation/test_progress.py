"""The progress bar counts whole units with their own rate (particles, cycles) and simulated seconds
with steps per second."""

import time

from rich.console import Console

from erosim.simulation import progress


def _rendered(monkeypatch, total, unit, done, steps) -> str:
    console = Console(record=True, width=160, force_terminal=False)
    real = progress.Progress.__init__

    def with_console(self, *args, **kwargs):
        real(self, *args, **{**kwargs, "console": console})

    monkeypatch.setattr(progress.Progress, "__init__", with_console)
    with progress.ProgressBar(total, "run", unit=unit) as bar:
        time.sleep(0.2)
        bar.update(done, steps)
    return console.export_text()


def test_counts_are_whole_numbers_with_their_own_rate(monkeypatch):
    text = _rendered(monkeypatch, 2000, "particles", 2000, steps=7)
    assert "2,000/2,000 particles" in text and "e+03" not in text
    rate = int(text.split("particles/s")[0].split()[-1].replace(",", ""))
    assert 2000 / 2.0 < rate <= 2000 / 0.2  # 2000 particles in 0.2 s and more, not 7 steps' worth


def test_simulated_time_shows_steps_per_second(monkeypatch):
    text = _rendered(monkeypatch, 0.5, "s", 0.25, steps=700)
    assert "0.25/0.5 s" in text
    rate = int(text.split("steps/s")[0].split()[-1].replace(",", ""))
    assert 700 / 2.0 < rate <= 700 / 0.2
