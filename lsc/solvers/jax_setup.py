"""JAX set-up shared by the JAX backends: a persistent compilation cache on disk.

The diffrax backend compiles one solver per scene structure; without a cache every new process
(each ``lsc run --method diffrax``) compiles again, seconds each time. With it, JAX writes each
compiled executable to the user's cache folder and a later process loads it instead.

Where: ``$LSC_JAX_CACHE`` if set (``0``, ``off`` or empty: no cache), else ``lsc/jax`` in the
user's cache folder (:func:`cache_dir`). Imported for its effect by :mod:`lsc.solvers.diffrax_ode`
right after ``import jax``, before anything is compiled.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import jax

__all__ = ["cache_dir", "enable_compilation_cache", "ENV", "MIN_COMPILE_TIME"]

#: The environment variable that moves (a folder) or turns off (``0``, ``off``, empty) the cache.
ENV = "LSC_JAX_CACHE"
#: Compilations faster than this [s] are not written to the cache (cheaper to redo than to read).
MIN_COMPILE_TIME = 0.1
_OFF = ("", "0", "off", "false", "no")


def _user_cache_root() -> Path:
    """The user's cache folder: platformdirs' answer where it is installed (pint depends on it),
    else ``%LOCALAPPDATA%`` (Windows), ``~/Library/Caches`` (macOS), ``$XDG_CACHE_HOME`` or
    ``~/.cache`` (elsewhere)."""
    try:
        from platformdirs import user_cache_dir
    except ImportError:
        pass
    else:
        return Path(user_cache_dir(appname=None, appauthor=False))
    if sys.platform == "win32":
        return Path(os.environ.get("LOCALAPPDATA") or Path.home() / "AppData" / "Local")
    if sys.platform == "darwin":
        return Path.home() / "Library" / "Caches"
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")


def cache_dir() -> Path | None:
    """The folder of the compilation cache, or ``None`` where ``$LSC_JAX_CACHE`` turns it off."""
    env = os.environ.get(ENV)
    if env is not None:
        return None if env.strip().lower() in _OFF else Path(env).expanduser()
    return _user_cache_root() / "lsc" / "jax"


def enable_compilation_cache() -> Path | None:
    """Point JAX's persistent compilation cache at :func:`cache_dir` (created if missing);
    returns the folder, or ``None`` when the cache is off or the folder cannot be created (then
    JAX compiles as without a cache: slower, never wrong)."""
    folder = cache_dir()
    if folder is None:
        return None
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError:
        return None
    jax.config.update("jax_compilation_cache_dir", str(folder))
    jax.config.update("jax_persistent_cache_min_compile_time_secs", MIN_COMPILE_TIME)
    jax.config.update("jax_persistent_cache_min_entry_size_bytes", 0)
    return folder


CACHE_DIR = enable_compilation_cache()
