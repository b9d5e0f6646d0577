"""Imported once by the forkserver of ``signatelec generate`` (multiprocessing preload).

Every local worker is forked from the forkserver, so it starts with these modules imported
(about 2 s of imports on a busy 2-core machine, paid once instead of once per worker). The
forkserver is started while the parent compiles the kernels, so the two overlap; each worker then
loads the compiled kernels from the on-disk cache in its initializer
(:func:`signatelec.data.runner.warm_up`). The forkserver dies with the job that started it
(:func:`signatelec.data.lifeline.init_forkserver`).
"""

from __future__ import annotations

import scipy.optimize  # noqa: F401
import scipy.signal  # noqa: F401
import scipy.stats  # noqa: F401

import signatelec.data  # noqa: F401
import signatelec.engines.dem.run  # noqa: F401
import signatelec.engines.fidelity  # noqa: F401
import signatelec.physics.electrical  # noqa: F401
import signatelec.physics.quasistatic  # noqa: F401
from signatelec.data.lifeline import init_forkserver

init_forkserver()
