"""signatelec: DEM ball-bearing simulator, electrical resistance signatures, load estimation.

The model is that of Machado, Guessasma and Bellenger, *Modelling of ball bearing loading by DEM
for electromechanical coupling* (the seed): a 2D SKF 6208 with Hertz-Mindlin contacts, a cage of
polyamide balls, and the bearing's resistance from the Kirchhoff network of its contacts.
"""

from signatelec._version import __version__

__all__ = ["__version__", "simulate"]


def simulate(scene=None, **kwargs):
    """Simulate a scene (default: the seed's); see :func:`signatelec.engines.simulate.simulate`."""
    from signatelec.engines.simulate import simulate as _simulate

    return _simulate(scene, **kwargs)


def __getattr__(name):
    if name in ("Scene", "Bearing"):
        from signatelec.config import bearing, scene

        return {"Scene": scene.Scene, "Bearing": bearing.Bearing}[name]
    raise AttributeError(name)
