"""Loaders of measured data: Silverbox, Cascaded tanks, a pendulum, Hudson's Bay hare and lynx pelts.

The files are looked for in the data home (see :func:`get_data_home`) with the layout
``silverbox/SNLS80mV.csv``, ``cascaded_tanks/dataBenchmark.csv``,
``pendulum_freeswing/SingleDataFreeSwing_1_Dt_0_0001.mat`` and ``hare_lynx/hudson-bay-lynx-hare.csv``.
When missing they are downloaded from the repositories that redistribute them and checked against
their SHA-256.
"""

from __future__ import annotations

import os

import numpy as np
from sklearn.utils import Bunch

from ._base import RemoteFile, fetch_file, read_csv_columns

__all__ = ["fetch_cascaded_tanks", "fetch_hare_lynx", "fetch_silverbox", "load_pendulum_freeswing"]

_RAW = "https://raw.githubusercontent.com"

# Addresses: the first URL pins the commit at which the file's folder is recorded in the
# repository's history; the mirror follows the default branch. The digest decides, not the URL.
SILVERBOX = RemoteFile(
    filename="silverbox/SNLS80mV.csv",
    url=f"{_RAW}/forgi86/pytorch-ident/e116bdf174281964e149e30f03c42c558a0a8559/"
    "examples/statespace/silverbox/SilverboxFiles/SNLS80mV.csv",
    mirrors=(f"{_RAW}/forgi86/pytorch-ident/master/examples/statespace/silverbox/"
             "SilverboxFiles/SNLS80mV.csv",),
    checksum="ae62d5a91230c10f76e6dd02c8a4fac3c9d4d8a95fbf50e87cb0c4885003e0f1",
)
CASCADED_TANKS = RemoteFile(
    filename="cascaded_tanks/dataBenchmark.csv",
    url=f"{_RAW}/forgi86/sysid-neural-structures-fitting/"
    "321df9b9d53829a5d425650380736404deefc01b/examples/CTS_example/data/dataBenchmark.csv",
    mirrors=(f"{_RAW}/forgi86/sysid-neural-structures-fitting/master/examples/CTS_example/"
             "data/dataBenchmark.csv",),
    checksum="ef2388ed822f3aef4aa80d6b0f2b466dd80b361786b3eafc7a2957c31ea323a7",
)
PENDULUM_FREESWING = RemoteFile(
    filename="pendulum_freeswing/SingleDataFreeSwing_1_Dt_0_0001.mat",
    url=f"{_RAW}/dynamicslab/MultiArm-Pendulum/main/Datas/SinglePendulum/"
    "SingleDataFreeSwing_1_Dt_0_0001.mat",
    mirrors=(f"{_RAW}/dynamicslab/MultiArm-Pendulum/8b6fb78203c6fed88d8a13a6dbd7929ddaeeec11/"
             "Datas/SinglePendulum/SingleDataFreeSwing_1_Dt_0_0001.mat",),
    checksum="5e6272350a91fb9fb99b6949bc49e3e63e21af977cc1f777310f5d8e9b0fc7e7",
)
HARE_LYNX = RemoteFile(
    filename="hare_lynx/hudson-bay-lynx-hare.csv",
    url=f"{_RAW}/stan-dev/example-models/3057930df98f3fe54ee32b1d6736a97ac0012ab6/"
    "knitr/lotka-volterra/hudson-bay-lynx-hare.csv",
    mirrors=(f"{_RAW}/stan-dev/example-models/master/knitr/lotka-volterra/hudson-bay-lynx-hare.csv",),
    checksum="b9d7bab8be18fe3b67e32e55e9888ad1847ff29dbc0de566070d0ff969adf14d",
)

PENDULUM_DT = 1e-4  # s; sampling time given in the repository's DataExplanation.md
SILVERBOX_FS = 1e7 / 2**14  # Hz; the benchmark's sample rate, 610.3516 Hz
# Splits used by the `nonlinear_benchmarks` package (0-based, half-open).
SILVERBOX_SPLITS = {
    "train": slice(40650, 105712),
    "test_multisine": slice(105712, 127400),
    "test_arrow_full": slice(100, 40575),
    "test_arrow_no_extrapolation": slice(100, 32100),
}
SILVERBOX_N_INIT = 50  # samples of each test record used to set the initial state

_SILVERBOX_DESCR = """Silverbox benchmark (measured), file SNLS80mV.csv
=================================================
An electronic circuit behaving as a mass-spring-damper with a cubic (Duffing) spring,
y'' m + d y' + k y + k3 y^3 = u. Source: nonlinearbenchmark.org (Pintelon, Schoukens, VUB);
copy redistributed in the MIT-licensed repository forgi86/pytorch-ident.

u (column V1): input voltage [V]; y (column V2): output voltage [V]; 131,072 samples at
fs = 10^7 / 2^14 = 610.3516 Hz. Samples [0, ~40,000) are the "arrow" (filtered Gaussian noise of
growing amplitude); then 10 odd random-phase multisines separated by short zero-input gaps. The
input carries a +6.2 mV offset in the gaps; the last 3,652 samples repeat the start of the file.

Standard splits (0-based, half-open), in ``splits`` and as arrays u_<name>, y_<name>:
  train                        [40650, 105712)  first 75 % of the multisine part
  test_multisine               [105712, 127400)
  test_arrow_full              [100, 40575)
  test_arrow_no_extrapolation  [100, 32100)     amplitudes within the training range
Protocol: the initial state of each test record is set from y[:50] of that record, and the RMSE
is computed on [50:] (``n_init`` = 50). How u is reconstructed between samples (zero-order
hold, linear, band-limited) changes simulation results markedly.
"""

_TANKS_DESCR = """Cascaded tanks benchmark (measured), file dataBenchmark.csv
===========================================================
Two cascaded water tanks with Torricelli outflow: a pump voltage u fills the upper tank, which
drains into the lower one; y is the water level of the lower tank. Source: Schoukens, Mattson,
Wigren, Noel, "Cascaded tanks benchmark combining soft and hard nonlinearities"
(4TU.ResearchData); copy redistributed in the MIT-licensed forgi86/sysid-neural-structures-fitting.

u_est, y_est: estimation record; u_val, y_val: validation record; 1,024 samples each, Ts = 4 s.
Overflow: the tanks overflow and the level sensor saturates, so y saturates at 10.0 (47 samples
of y_est and 37 of y_val are exactly 10). A model without overflow cannot follow those parts.
Usual protocol: validation initial state fitted on y_val[:5], RMSE on [5:].
"""

_PENDULUM_DESCR = """Pendulum free swing (measured), file SingleDataFreeSwing_1_Dt_0_0001.mat
=========================================================================
A real single pendulum swinging freely on a fixed cart (Kaheman et al., arXiv 2205.06231;
MIT-licensed repository dynamicslab/MultiArm-Pendulum). The encoder angle ``angle`` is in rad as
stored (resolution 2 pi / 40000); the bottom rest position is about 3.141, not 0. ``t`` is the
recording clock as stored (it starts at 60 s); dt = 1e-4 s. The amplitude is about 0.067 rad and
decays to rest in about 10 s through friction.

angle_from_bottom = angle - rest_angle, where rest_angle is the median of the last 10 % of the
record (the pendulum is at rest there). With ``decimate`` = k only every k-th sample is kept
(plain subsampling; the signal is far below the Nyquist rate of 5 kHz).
"""

_HARE_LYNX_DESCR = """Hudson's Bay Company hare and lynx pelts, file hudson-bay-lynx-hare.csv
=======================================================================
Numbers of snowshoe hare and Canadian lynx pelts traded, in thousands, one count a year from 1900
to 1920 (21 years): the classic test of the Lotka-Volterra predator-prey model, whose cycles of
about ten years the counts follow. Pelts are a proxy for the populations (trapping effort varies).
Source: Howard, "Modeling basics" (course notes, Texas A&M); copy in the BSD-licensed repository
stan-dev/example-models (knitr/lotka-volterra), whose Lotka-Volterra case study fits these counts.

year, hare, lynx : ndarray of shape (21,).
"""


def fetch_silverbox(
    data_home: str | os.PathLike | None = None, download_if_missing: bool = True
) -> Bunch:
    """Load the measured Silverbox benchmark (electronic Duffing oscillator).

    Parameters
    ----------
    data_home : str or path-like, default=None
        Data home folder, see :func:`get_data_home`.
    download_if_missing : bool, default=True
        Whether to download the file when it is not in the data home.

    Returns
    -------
    data : Bunch
        ``u``, ``y`` : ndarray of shape (131072,), input and output voltages [V];
        ``fs`` : sample rate [Hz]; ``splits`` : dict of name to slice; for every split name
        ``u_<name>`` and ``y_<name>`` arrays; ``n_init`` : 50; ``DESCR``.
    """
    path = fetch_file(SILVERBOX, data_home, download_if_missing)
    cols = read_csv_columns(path, ["V1", "V2"])
    data = Bunch(u=cols["V1"], y=cols["V2"], fs=SILVERBOX_FS, splits=dict(SILVERBOX_SPLITS),
                 n_init=SILVERBOX_N_INIT, filename=str(path), DESCR=_SILVERBOX_DESCR)
    for name, sl in SILVERBOX_SPLITS.items():
        data[f"u_{name}"] = data.u[sl]
        data[f"y_{name}"] = data.y[sl]
    return data


def fetch_cascaded_tanks(
    data_home: str | os.PathLike | None = None, download_if_missing: bool = True
) -> Bunch:
    """Load the measured Cascaded tanks benchmark.

    Parameters
    ----------
    data_home : str or path-like, default=None
        Data home folder, see :func:`get_data_home`.
    download_if_missing : bool, default=True
        Whether to download the file when it is not in the data home.

    Returns
    -------
    data : Bunch
        ``u_est``, ``y_est``, ``u_val``, ``y_val`` : ndarray of shape (1024,);
        ``Ts`` : 4.0 (s); ``y_max`` : 10.0 (saturation level of y); ``DESCR``.
    """
    path = fetch_file(CASCADED_TANKS, data_home, download_if_missing)
    cols = read_csv_columns(path, ["uEst", "yEst", "uVal", "yVal"])
    ts = float(read_csv_columns(path, ["Ts"], max_rows=1)["Ts"][0])
    return Bunch(u_est=cols["uEst"], y_est=cols["yEst"], u_val=cols["uVal"], y_val=cols["yVal"],
                 Ts=ts, y_max=10.0, filename=str(path), DESCR=_TANKS_DESCR)


def load_pendulum_freeswing(
    data_home: str | os.PathLike | None = None,
    download_if_missing: bool = True,
    decimate: int | None = None,
) -> Bunch:
    """Load the measured free swing of a real pendulum (encoder angle at 10 kHz).

    Parameters
    ----------
    data_home : str or path-like, default=None
        Data home folder, see :func:`get_data_home`.
    download_if_missing : bool, default=True
        Whether to download the file when it is not in the data home.
    decimate : int, default=None
        Keep every ``decimate``-th sample; None or 1 keeps all.

    Returns
    -------
    data : Bunch
        ``t`` : ndarray of shape (n,), recording time [s] as stored; ``angle`` : ndarray of
        shape (n,), encoder angle [rad] as stored; ``dt`` : sample period [s] after decimation;
        ``rest_angle`` : angle at rest (median of the last 10 % of the full record);
        ``angle_from_bottom`` : ``angle - rest_angle``; ``DESCR``.
    """
    from scipy.io import loadmat

    if decimate is None:
        decimate = 1
    if isinstance(decimate, bool) or not isinstance(decimate, (int, np.integer)) or decimate < 1:
        raise ValueError(f"decimate must be a positive integer or None, got {decimate!r}.")
    path = fetch_file(PENDULUM_FREESWING, data_home, download_if_missing)
    theta = loadmat(path, simplify_cells=True)["Theta1"]
    t = np.asarray(theta["time"], dtype=np.float64).ravel()
    angle = np.asarray(theta["signals"]["values"], dtype=np.float64).ravel()
    rest = float(np.median(angle[-max(1, angle.size // 10):]))
    dt = PENDULUM_DT * decimate
    t, angle = t[::decimate].copy(), angle[::decimate].copy()
    return Bunch(t=t, angle=angle, dt=dt, rest_angle=rest, angle_from_bottom=angle - rest,
                 decimate=int(decimate), filename=str(path), DESCR=_PENDULUM_DESCR)


def fetch_hare_lynx(
    data_home: str | os.PathLike | None = None, download_if_missing: bool = True
) -> Bunch:
    """Load the Hudson's Bay Company hare and lynx pelt counts, 1900-1920.

    Parameters
    ----------
    data_home : str or path-like, default=None
        Data home folder, see :func:`get_data_home`.
    download_if_missing : bool, default=True
        Whether to download the file when it is not in the data home.

    Returns
    -------
    data : Bunch
        ``year``, ``hare``, ``lynx`` : ndarray of shape (21,), pelts in thousands; ``DESCR``.
    """
    path = fetch_file(HARE_LYNX, data_home, download_if_missing)
    cols = read_csv_columns(path, ["Year", "Hare", "Lynx"])
    return Bunch(year=cols["Year"], hare=cols["Hare"], lynx=cols["Lynx"], filename=str(path),
                 DESCR=_HARE_LYNX_DESCR)
