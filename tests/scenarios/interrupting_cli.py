"""``python interrupting_cli.py PHASE N PRESSES -- <erosim arguments>``: the real ``erosim`` command,
sent SIGINT (Ctrl-C) by its own process at a chosen moment, PRESSES times in a row:

* ``step``: just before the N-th iteration's models advance (the press lands inside the step);
* ``output``: just before the N-th callback call that writes (frames, snapshots, maps, probes);
* ``final``: just before the N-th final output (the callbacks' ``finalize``: maps, figures).

Used by ``test_interrupt_resume.py``; the signal is the one a terminal sends, so the command's own
handling (held first press, checkpoint, resume hint, exit code) is what is tested.
"""

import os
import signal
import sys

from erosim.cli import main
from erosim.simulation import simulation as simmod
from erosim.simulation.callbacks import Checkpointer


def press(times: int) -> None:
    for _ in range(times):
        os.kill(os.getpid(), signal.SIGINT)


def install(phase: str, n: int, presses: int) -> None:
    count = [0]

    def due() -> bool:
        count[0] += 1
        return count[0] == n

    if phase == "step":
        real_step = simmod.Simulation._step

        def step(self):
            if due():
                press(presses)
            real_step(self)

        simmod.Simulation._step = step
    elif phase == "output":

        def fire(self):
            for c in self.callbacks:
                if c.schedule(self):
                    if not isinstance(c, Checkpointer) and due():
                        press(presses)
                    c(self)

        simmod.Simulation._fire = fire
    elif phase == "final":
        real_run = simmod.Simulation.run

        def run(self, **kwargs):
            for c in self.callbacks:
                real_finalize = c.finalize

                def finalize(sim, real_finalize=real_finalize):
                    if due():
                        press(presses)
                    return real_finalize(sim)

                c.finalize = finalize
            return real_run(self, **kwargs)

        simmod.Simulation.run = run
    else:
        raise SystemExit(f"unknown phase {phase}")


if __name__ == "__main__":
    phase, n, presses, sep, *args = sys.argv[1:]
    assert sep == "--"
    install(phase, int(n), int(presses))
    sys.argv = ["erosim", *args]
    main()
