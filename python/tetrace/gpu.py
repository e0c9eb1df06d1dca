"""GPU casting through wgpu compute shaders: adapters, the device, the kernels.

The default kernel, ``exact`` on tet20, keeps the exact contract on the GPU: the CPU begins
each ray's exact walk (location, the first exit), the GPU takes every step of the walk it can
certify with float32 error bounds (the robust kernel's, plus the points' rounding to float32),
and the CPU exact walk goes on from where the GPU stopped: at the face the query decides, or
at a step too close to call. Every answer is then the CPU exact cast's, bit for bit. The
papers' float32 kernels remain (method on layout): Aman et al. 2022 on tet20, Maria et al.
2017 on tet80, and the robust walk on tet20, whose float32 filter hands the rays it cannot
certify back to the CPU robust walk. Design: ``docs/gpu.md``.

Any Vulkan, Metal, DX12 or OpenGL adapter with compute shaders works; on a Linux machine
without a GPU, Mesa's software Vulkan driver (lavapipe, ``apt-get install
mesa-vulkan-drivers``) provides one. ``WGPU_BACKEND`` (e.g. ``vulkan``) narrows the search.

An extension built without the ``gpu`` cargo feature (the wheel has it) has no kernels: there
:func:`info`, :func:`device` and ``device="gpu"`` raise :class:`GpuError` saying so, and
:func:`available` is False.
"""

from __future__ import annotations

from functools import lru_cache

from . import _native

__all__ = ["GpuError", "info", "device", "available", "hardware", "kernels", "DEFAULT_KERNEL"]

# How ``Scene.cast`` routes a cast to the GPU (:func:`check_cast`, :func:`wanted`):
# functions of the cast's arguments, so that this module imports nothing of tetrace.scene.

#: Raised when no adapter can run the kernels, the device fails, or the extension was built
#: without GPU support.
GpuError = _native.GpuError


def kernels():
    """Return the GPU kernels as ``(method, layout)`` pairs, the default first.

    Returns
    -------
    list of tuple of str
    """
    return [tuple(k) for k in _native.gpu_kernels()]


#: The kernel ``device="gpu"`` uses when neither method nor layout is given (None in a build
#: without GPU support: there :func:`kernels` is empty and the rest raise :class:`GpuError`).
DEFAULT_KERNEL = (kernels() or [None])[0]


def kernel_for(method=None, layout=None):
    """Return the ``(method, layout)`` kernel a GPU cast uses, or None if there is none.

    A missing method means the default kernel's; a missing layout means the layout of the
    first kernel for that method (tet80 for ``maria2017``, tet20 otherwise). The rule is the
    core's (``KernelSpec::find`` in ``src/gpu/kernels.rs``), which a GPU cast applies too.

    Parameters
    ----------
    method, layout : str, optional

    Returns
    -------
    tuple of str or None
    """
    try:
        return tuple(_native.gpu_kernel_for(method, layout))
    except (ValueError, TypeError):  # no such kernel; a name that is not a str names none
        return None


def info():
    """List the adapters wgpu finds, best first; the first with compute shaders is used.

    Returns
    -------
    list of dict
        ``name``, ``backend`` (Vulkan, Metal, Dx12, Gl), ``device_type`` (DiscreteGpu,
        IntegratedGpu, VirtualGpu, Cpu for software drivers such as lavapipe, Other),
        ``driver``, ``driver_info``, ``vendor``, ``device``, ``compute`` (runs compute shaders),
        ``max_storage_buffer_binding_size``, ``max_buffer_size`` (bytes).

    Raises
    ------
    GpuError
        No adapter with compute shaders; the message names the backends looked for.
    """
    found = _native.gpu_adapters()
    if not any(a["compute"] for a in found):
        _native.gpu_device()  # raises GpuError naming what was looked for
    return found


def device():
    """Return the adapter GPU casts run on, opening its device on first use.

    Returns
    -------
    dict
        As in :func:`info`, plus the limits the device was opened with
        (``device_max_storage_buffer_binding_size``, ``device_max_buffer_size``),
        ``timestamps`` (the kernel's time comes from GPU timestamps) and
        ``mapped_results`` (the device shares memory with the host, so results are read
        where the kernel wrote them, with no copy to a readback buffer).

    Raises
    ------
    GpuError
        No adapter with compute shaders, or the device could not be opened.
    """
    return _native.gpu_device()


@lru_cache(maxsize=1)
def available():
    """Return whether a GPU device can be opened (checked once per process).

    Returns
    -------
    bool
    """
    try:
        _native.gpu_device()
    except GpuError:
        return False
    return True


def check_cast(device):
    """Refuse a ``device`` that does not exist (``Scene.cast``'s argument), before the rays
    are checked. What a GPU cast cannot take (another accel, ``start=hits``, float64) the
    core refuses as it is asked (``NativeScene.cast_gpu``)."""
    if device not in ("cpu", "gpu", "auto"):
        raise ValueError(f'device must be "cpu", "gpu" or "auto", got {device!r}')


def hardware():
    """Return whether the device GPU casts run on is a hardware GPU (not a software driver
    such as lavapipe, which runs the kernels on the CPU, slower than the CPU walk).

    Returns
    -------
    bool
    """
    return available() and device().get("device_type") != "Cpu"


def wanted(device, precision, method, layout, accel, start):
    """Whether a cast of rays of ``precision`` (``"f32"`` or ``"f64"``, the walk's) runs on
    the GPU: always for ``device="gpu"``; for ``"auto"``, when a float32 tet walk has a kernel
    and a device opens: for the exact default on a hardware GPU (:func:`hardware`; the GPU's
    answers are the CPU's, so only speed is at stake), for a method named explicitly on any
    adapter."""
    if device == "gpu":
        return True
    if device == "auto" and precision == "f32":
        if accel not in (None, "tetwalk") or start is not None:
            return False
        if kernel_for(method, layout) is None or not available():
            return False
        return method is not None or hardware()
    return False


def deprecated_timings():
    """``Scene.gpu_timings``: warn that it is deprecated (at the caller's line), and None."""
    import warnings

    warnings.warn(
        "Scene.gpu_timings is deprecated and always None: read hits.timings of the GPU "
        "cast's result",
        DeprecationWarning,
        stacklevel=3,
    )
