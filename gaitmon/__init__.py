"""gaitmon: live monitor, recorder and reviewer for a wearable lower-limb gait-measurement unit.

For researchers, a small public API (:mod:`gaitmon.api`, README "For researchers")::

    import gaitmon
    with gaitmon.open("walk.h5") as rec:
        angles = rec.angles()          # joint and segment angles, numpy arrays + time
        strides = rec.strides()        # the stride table of gaitmon info / the report

``gaitmon.open``, ``Recording``, ``Angles`` and ``Events`` are imported on first use (PEP 562),
so ``import gaitmon`` (and ``gaitmon --version``) loads nothing but this file.
"""

# The one place the version is written (pyproject.toml reads it): a constant, so every command
# knows it without the ~0.1 s that importlib.metadata costs at start-up.
__version__ = "0.1.0"

TYPE_CHECKING = False  # (not typing's: importing typing costs this one-file import ~3 ms)
if TYPE_CHECKING:
    from gaitmon.api import Angles, Events, Recording, open

_API = ("open", "Recording", "Angles", "Events")


def __getattr__(name: str) -> object:
    """The public API's names, from :mod:`gaitmon.api` on first use (see the module doc)."""
    if name in _API:
        from gaitmon import api
        from gaitmon.lazy import keep

        return keep(globals(), name, api)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted([*globals(), *_API])


__all__ = ["Angles", "Events", "Recording", "__version__", "open"]
