"""Tests of the dataset loaders: checked downloads, zip extraction, parsing, real shared files."""

import hashlib
import re
import zipfile
from pathlib import Path

import numpy as np
import pytest

from sklearn_hybrid.datasets import (
    fetch_cascaded_tanks,
    fetch_hare_lynx,
    fetch_light_tunnel,
    fetch_silverbox,
    fetch_wind_tunnel,
    get_data_home,
    load_pendulum_freeswing,
    make_light_tunnel_simulated,
    make_wind_tunnel_simulated,
)
from sklearn_hybrid.datasets import _causal_chamber as cc
from sklearn_hybrid.models import causal_chamber as chamber
from sklearn_hybrid.datasets import _causal_chamber_simulated as cc_sim
from sklearn_hybrid.datasets import _measured
from sklearn_hybrid.datasets._base import (
    ChecksumError,
    RemoteFile,
    extract_zip,
    fetch_file,
    read_csv_columns,
)


def _sha(path, algo="sha256"):
    return hashlib.new(algo, Path(path).read_bytes()).hexdigest()


def _leftovers(folder):
    return [p.name for p in Path(folder).rglob("*") if p.name.startswith(".")]


# --------------------------------------------------------------------------------------------
# _base: data home, checked fetch, zip extraction


def _fake_checkout(tmp_path, monkeypatch, shared=True):
    """The package as if it ran from the source checkout ``tmp_path/repo``, with ``tmp_path/shared/data``."""
    import sklearn_hybrid.datasets._base as base

    (tmp_path / "repo").mkdir()
    (tmp_path / "repo" / "pyproject.toml").write_text("")
    if shared:
        (tmp_path / "shared" / "data").mkdir(parents=True)
    monkeypatch.setattr(base, "__file__", str(tmp_path / "repo" / "sklearn_hybrid" / "datasets" / "_base.py"))
    return tmp_path / "shared" / "data"


def test_get_data_home_precedence(tmp_path, monkeypatch):
    monkeypatch.setenv("SKLEARN_HYBRID_DATA", str(tmp_path / "env"))
    assert get_data_home(tmp_path / "arg") == tmp_path / "arg"
    assert get_data_home() == tmp_path / "env"
    monkeypatch.delenv("SKLEARN_HYBRID_DATA")
    monkeypatch.setenv("HOME", str(tmp_path))
    shared = _fake_checkout(tmp_path, monkeypatch)  # a source checkout with ../shared/data: that folder
    assert get_data_home() == shared
    shared.rmdir()  # without it (or installed, no pyproject.toml beside the package): the home folder
    assert get_data_home() == tmp_path / "sklearn_hybrid_data"
    assert not (tmp_path / "sklearn_hybrid_data").exists()  # not created as a side effect


def test_default_data_home_is_the_one_the_tests_and_docs_use():
    """The package's default in this checkout is the folder tests/conftest.py and doc/conf.py point at."""
    import sklearn_hybrid
    import sklearn_hybrid.datasets._base as base

    repo = Path(__file__).resolve().parents[1]
    shared = repo.parent / "shared" / "data"
    if not shared.is_dir() or Path(sklearn_hybrid.__file__).resolve().parents[1].parent != repo.parent:
        pytest.skip("no ../shared/data beside this checkout")
    assert base._checkout_data() == shared
    assert 'HERE.parent.parent / "shared" / "data"' in (repo / "doc" / "conf.py").read_text()


@pytest.fixture
def source_file(tmp_path):
    src = tmp_path / "published" / "data.csv"
    src.parent.mkdir()
    src.write_text('"a","b",\n1,2,\n3,4,\n')
    return src


def test_fetch_file_present_checksum_ok(tmp_path, source_file):
    home = tmp_path / "home"
    (home / "sub").mkdir(parents=True)
    (home / "sub" / "data.csv").write_bytes(source_file.read_bytes())
    for algo in ("sha256", "md5"):
        remote = RemoteFile("sub/data.csv", "file:///nowhere", _sha(source_file, algo), algo)
        assert fetch_file(remote, home, download_if_missing=False) == home / "sub" / "data.csv"


def test_fetch_file_checksum_mismatch_names_file_and_digests(tmp_path, source_file):
    home = tmp_path / "home"
    (home / "sub").mkdir(parents=True)
    local = home / "sub" / "data.csv"
    local.write_text("something else\n")
    expected = _sha(source_file)
    with pytest.raises(ChecksumError) as err:
        fetch_file(RemoteFile("sub/data.csv", "file:///nowhere", expected), home)
    msg = str(err.value)
    assert str(local) in msg and expected in msg and _sha(local) in msg


def test_fetch_file_no_download_names_full_path_and_source(tmp_path):
    remote = RemoteFile("sub/data.csv", "https://example.invalid/data.csv", "0" * 64)
    with pytest.raises(FileNotFoundError) as err:
        fetch_file(remote, tmp_path, download_if_missing=False)
    msg = str(err.value)
    assert str(tmp_path / "sub" / "data.csv") in msg and remote.url in msg
    assert not (tmp_path / "sub").exists()


def test_fetch_file_downloads_verifies_and_moves(tmp_path, source_file):
    remote = RemoteFile("sub/data.csv", source_file.as_uri(), _sha(source_file))
    path = fetch_file(remote, tmp_path / "home")
    assert path.read_bytes() == source_file.read_bytes()
    assert _leftovers(tmp_path / "home") == []


def test_fetch_file_bad_download_leaves_nothing(tmp_path, source_file):
    remote = RemoteFile("sub/data.csv", source_file.as_uri(), "f" * 64)
    with pytest.raises(ChecksumError, match="Nothing was written"):
        fetch_file(remote, tmp_path / "home")
    assert not (tmp_path / "home").exists()  # the folders it made for the file are gone too
    other = tmp_path / "other.csv"
    other.write_text("not it\n")
    remote = RemoteFile("sub/data.csv", other.as_uri(), _sha(source_file),
                        mirrors=(source_file.as_uri(),))
    assert fetch_file(remote, tmp_path / "home").read_bytes() == source_file.read_bytes()


def test_fetch_file_offline_error_and_mirror(tmp_path, source_file):
    dead = (tmp_path / "missing.csv").as_uri()
    remote = RemoteFile("sub/data.csv", dead, _sha(source_file))
    with pytest.raises(FileNotFoundError) as err:
        fetch_file(remote, tmp_path / "home")
    assert str(tmp_path / "home" / "sub" / "data.csv") in str(err.value)
    assert dead in str(err.value)
    assert not (tmp_path / "home").exists()  # an offline attempt leaves no empty folder
    (tmp_path / "home").mkdir()
    with pytest.raises(FileNotFoundError):
        fetch_file(remote, tmp_path / "home")
    assert list((tmp_path / "home").iterdir()) == []  # a folder that was there stays
    remote = RemoteFile("sub/data.csv", dead, _sha(source_file), mirrors=(source_file.as_uri(),))
    assert fetch_file(remote, tmp_path / "home").is_file()


def test_remote_file_rejects_bad_fields():
    with pytest.raises(ValueError, match="algorithm"):
        RemoteFile("a.csv", "u", "0", algorithm="sha1")
    with pytest.raises(ValueError, match="relative"):
        RemoteFile("../a.csv", "u", "0")


def test_extract_zip(tmp_path):
    zpath = tmp_path / "a.zip"
    with zipfile.ZipFile(zpath, "w") as z:
        z.writestr("top/x.csv", "1\n")
        z.writestr("top/sub/y.txt", "2")
        z.writestr("__MACOSX/top/._x.csv", "junk")
    out = extract_zip(zpath, tmp_path / "dest", "top")
    assert (out / "x.csv").read_text() == "1\n" and (out / "sub" / "y.txt").exists()
    assert sorted(p.name for p in (tmp_path / "dest").iterdir()) == ["top"]
    with pytest.raises(FileExistsError):
        extract_zip(zpath, tmp_path / "dest", "top")
    bad = tmp_path / "bad.zip"
    with zipfile.ZipFile(bad, "w") as z:
        z.writestr("top/ok.csv", "1")
        z.writestr("top/../../evil.txt", "x")
    with pytest.raises(ValueError, match="Unsafe"):
        extract_zip(bad, tmp_path / "dest2", "top")
    assert not (tmp_path / "dest2").exists() and not (tmp_path / "evil.txt").exists()
    with pytest.raises(ValueError, match="no folder"):
        extract_zip(zpath, tmp_path / "dest3", "other")


def test_read_csv_trailing_comma_header(source_file):
    cols = read_csv_columns(source_file, ["b", "a"])
    np.testing.assert_array_equal(cols["a"], [1, 3])
    np.testing.assert_array_equal(cols["b"], [2, 4])
    with pytest.raises(ValueError, match="no column"):
        read_csv_columns(source_file, ["c"])


# --------------------------------------------------------------------------------------------
# Measured benchmarks: tiny files, then the real shared files


def test_silverbox_tiny_file_and_offline_error(tmp_path, monkeypatch):
    home = tmp_path / "home"
    (home / "silverbox").mkdir(parents=True)
    f = home / "silverbox" / "SNLS80mV.csv"
    f.write_text('"V1","V2",\n' + "".join(f"{i},{-i},\n" for i in range(130000)))
    with pytest.raises(ChecksumError):  # not the published file
        fetch_silverbox(home)
    monkeypatch.setattr(_measured, "SILVERBOX",
                        RemoteFile("silverbox/SNLS80mV.csv", "file:///x", _sha(f)))
    d = fetch_silverbox(home)
    assert d.u.shape == (130000,) and d.y[7] == -7 and len(d.u_train) == 105712 - 40650
    with pytest.raises(FileNotFoundError, match=re.escape(str(tmp_path / "empty" / "silverbox"))):
        fetch_silverbox(tmp_path / "empty", download_if_missing=False)


def test_hare_lynx_tiny_file_with_comment_lines(tmp_path, monkeypatch):
    home = tmp_path / "home"
    (home / "hare_lynx").mkdir(parents=True)
    f = home / "hare_lynx" / "hudson-bay-lynx-hare.csv"
    f.write_text("# counts\n# in thousands\nYear, Lynx, Hare\n1900, 4.0, 30.0\n1901, 6.1, 47.2\n")
    with pytest.raises(ChecksumError):  # not the published file
        fetch_hare_lynx(home)
    monkeypatch.setattr(_measured, "HARE_LYNX", RemoteFile("hare_lynx/hudson-bay-lynx-hare.csv", "file:///x", _sha(f)))
    d = fetch_hare_lynx(home)
    np.testing.assert_array_equal(d.year, [1900, 1901])
    np.testing.assert_array_equal(d.hare, [30.0, 47.2])  # columns by name, not position
    np.testing.assert_array_equal(d.lynx, [4.0, 6.1])
    with pytest.raises(FileNotFoundError, match="hare_lynx"):
        fetch_hare_lynx(tmp_path / "empty", download_if_missing=False)


def test_hare_lynx_real(shared_data):
    d = fetch_hare_lynx(shared_data)
    assert d.year[0] == 1900 and d.year[-1] == 1920 and d.hare.shape == d.lynx.shape == (21,)
    assert (d.hare[3], d.lynx[4]) == (77.4, 59.4)  # the 1903 hare and 1904 lynx peaks


def test_silverbox_real(shared_data):
    d = fetch_silverbox()  # found through SKLEARN_HYBRID_DATA (tests/conftest.py)
    assert d.u.shape == d.y.shape == (131072,)
    assert d.fs == pytest.approx(610.3515625)
    assert (d.u[0], d.y[0]) == (0.0057756, 0.0093978)  # header with trailing comma skipped
    sizes = {k: len(d[f"y_{k}"]) for k in d.splits}
    assert sizes == {"train": 65062, "test_multisine": 21688, "test_arrow_full": 40475,
                     "test_arrow_no_extrapolation": 32000}
    assert d.n_init == 50 and "RMSE" in d.DESCR


def test_cascaded_tanks_real(shared_data):
    d = fetch_cascaded_tanks(shared_data)
    assert all(d[k].shape == (1024,) for k in ("u_est", "y_est", "u_val", "y_val"))
    assert d.Ts == 4.0
    assert d.y_est.max() == d.y_val.max() == 10.0
    assert (d.y_est == 10).sum() == 47 and (d.y_val == 10).sum() == 37


def test_pendulum_real(shared_data):
    d = load_pendulum_freeswing(shared_data)
    assert d.t.shape == d.angle.shape == (231757,)
    assert d.dt == 1e-4 and np.allclose(np.diff(d.t), 1e-4, atol=1e-9)
    assert d.rest_angle == pytest.approx(3.1411, abs=1e-3)
    assert 0.06 < np.abs(d.angle_from_bottom).max() < 0.07
    dec = load_pendulum_freeswing(shared_data, decimate=100)
    assert dec.dt == pytest.approx(1e-2) and dec.angle.shape == (2318,)
    with pytest.raises(ValueError, match="decimate"):
        load_pendulum_freeswing(shared_data, decimate=0)


def test_light_constants_match_calibration_files(shared_data):
    # S = camera sensitivity (normalised to the green peak) interpolated at the LED wavelengths.
    rows = (shared_data / "causal_chamber" / "camera_sensitivity.csv").read_text().split()
    waves = np.array(rows[0].split(",")[1:], dtype=float)
    sens = np.array([r.split(",")[1:] for r in rows[1:4]], dtype=float)
    sens /= sens[1].max()
    leds = [624.6, 517.8, 465.0]
    S = np.array([[np.interp(w, waves, s) for w in leds] for s in sens])
    np.testing.assert_allclose(S, chamber.S_CAMERA, atol=1e-6)


# --------------------------------------------------------------------------------------------
# Causal chambers: tiny files in the publisher's layout, zipped


def _wt_zip(folder, n_rows=10000, runs=(1, 2, 3, 4, 5)):
    """wt_walks_v1.zip with loads_hatch_mix_fast_run_<k>.csv (placeholder values) + extras."""
    zpath = folder / "wt_walks_v1.zip"
    u = cc_sim.wind_tunnel_inputs(n_rows)
    with zipfile.ZipFile(zpath, "w") as z:
        for k in runs:
            t = np.arange(n_rows)
            table = np.column_stack([t * 0.1, u["load_in"], u["load_out"], u["hatch"], t + k,
                                     1000.0 * k + t, np.full(n_rows, 3000.0)])
            head = "timestamp,load_in,load_out,hatch,pressure_downwind,pressure_ambient,rpm_in\n"
            body = "\n".join(",".join(f"{v:g}" for v in row) for row in table)
            z.writestr(f"wt_walks_v1/loads_hatch_mix_fast_run_{k}.csv", head + body + "\n")
        z.writestr("wt_walks_v1/loads_hatch_mix_slow_run_1.csv", "load_in\n1\n")
    return zpath


@pytest.fixture(scope="module")
def wt_zip(tmp_path_factory):
    return _wt_zip(tmp_path_factory.mktemp("wt"))


def test_wind_tunnel_from_local_zip(tmp_path, monkeypatch, wt_zip):
    home = tmp_path / "home"
    (home / "causal_chamber").mkdir(parents=True)
    local_zip = home / "causal_chamber" / "wt_walks_v1.zip"
    local_zip.write_bytes(wt_zip.read_bytes())
    with pytest.raises(ChecksumError):  # a placeholder zip is not the publisher's
        fetch_wind_tunnel(home, download_if_missing=False)
    monkeypatch.setattr(cc, "WT_WALKS", RemoteFile("causal_chamber/wt_walks_v1.zip", "file:///x",
                                                   _sha(wt_zip, "md5"), "md5"))
    d = fetch_wind_tunnel(home, download_if_missing=False)
    assert d.X.shape == (985, 200, 3) and d.y.shape == d.pressure_ambient.shape == (985, 200)
    assert np.bincount(d.run).tolist() == [0, 197, 197, 197, 197, 197]
    assert [(s.start, s.stop) for s in d.splits.values()] == [(0, 600), (600, 750), (750, 985)]
    assert d.X_train.shape[0] == 600 and d.y_val.shape[0] == 150 and d.X_test.shape[0] == 235
    i = 197 + 3  # run 2, 4th window: rows 150..349 of that run
    np.testing.assert_array_equal(d.y[i], np.arange(150, 350) + 2)
    np.testing.assert_array_equal(d.X[i, :, 0], cc_sim.wind_tunnel_inputs()["load_in"][150:350])
    assert d.theta_reference == {"r": 0.7} and d.theta_reference_code == {"r": 0.75}
    assert local_zip.exists() and not d.simulated  # a zip put there by the user is kept
    shorter = fetch_wind_tunnel(home, window=1000, stride=1000)  # extracted folder is reused
    assert shorter.X.shape == (50, 1000, 3)


def test_wind_tunnel_download_and_offline_error(tmp_path, monkeypatch, wt_zip):
    with pytest.raises(FileNotFoundError) as err:
        fetch_wind_tunnel(tmp_path / "a", download_if_missing=False)
    msg = str(err.value)
    assert str(tmp_path / "a" / "causal_chamber" / "wt_walks_v1.zip") in msg
    assert "wt_walks_v1.zip" in cc.WT_WALKS.url and cc.WT_WALKS.url in msg
    monkeypatch.setattr(cc, "WT_WALKS", RemoteFile("causal_chamber/wt_walks_v1.zip",
                                                   wt_zip.as_uri(), _sha(wt_zip, "md5"), "md5"))
    d = fetch_wind_tunnel(tmp_path / "b")
    assert d.X.shape == (985, 200, 3)
    assert sorted(p.name for p in (tmp_path / "b" / "causal_chamber").iterdir()) == ["wt_walks_v1"]


def test_windowing_counts():
    rows = np.arange(10000.0)
    assert cc._windows(rows, 200, 50).shape == (197, 200)
    assert cc._windows(np.zeros((10000, 3)), 200, 50).shape == (197, 200, 3)
    assert cc._windows(rows[:150], 200, 50).shape == (0, 200)
    assert cc._split(95, (6000, 1000, 2500)) == {"train": slice(0, 60), "val": slice(60, 70),
                                                 "test": slice(70, 95)}
    # a 9-sample file: the proportional cut would leave validation empty; every part keeps a sample
    assert cc._split(9, (6000, 1000, 2500)) == {"train": slice(0, 4), "val": slice(4, 5), "test": slice(5, 9)}
    with pytest.raises(ValueError, match="2 samples cannot be split"):
        cc._split(2, (600, 150, 235))
    with pytest.raises(ValueError, match="window"):
        make_wind_tunnel_simulated(n_runs=1, window=0)
    # a zero time step would leave the fans still (targets of noise alone); nothing is silently empty
    for make, options, message in [(make_wind_tunnel_simulated, {"dt": 0}, "dt must be > 0"),
                                   (make_wind_tunnel_simulated, {"dt": np.nan}, "dt must be finite"),
                                   (make_wind_tunnel_simulated, {"n_runs": 0}, "n_runs must be"),
                                   (make_wind_tunnel_simulated, {"n_steps": 100}, "n_steps must be an integer >= 200"),
                                   (make_light_tunnel_simulated, {"n_samples": -3}, "n_samples must be"),
                                   (make_light_tunnel_simulated, {"image_size": 0}, "image_size must be")]:
        with pytest.raises(ValueError, match=message):
            make(**options)


def _lt_tree(home, n=12, fmt="png"):
    """lt_camera_v1/<experiment>/<experiment>.csv + images_100/, known uniform colours."""
    from PIL import Image

    exp = home / "causal_chamber" / "lt_camera_v1" / cc.LT_EXPERIMENT
    (exp / "images_100").mkdir(parents=True)
    lines = ["red,green,blue,pol_1,pol_2,current,image_file"]
    for i in range(n):
        name = f"image_{i}.{fmt}"
        Image.new("RGB", (100, 100), (i, 2 * i, 255 - i)).save(exp / "images_100" / name)
        lines.append(f"{i},{2 * i},{255 - i},{-90 + i}.5,{i}.0,0.1,{name}")
    (exp / f"{cc.LT_EXPERIMENT}.csv").write_text("\n".join(lines) + "\n")
    return exp


def test_light_tunnel_from_extracted_folder(tmp_path):
    _lt_tree(tmp_path)
    d = fetch_light_tunnel(tmp_path, download_if_missing=False)
    assert d.X.shape == (12, 5) and d.images.shape == (12, 3, 100, 100)
    assert d.images.dtype == np.float32
    np.testing.assert_allclose(d.images[5, :, 40, 60], np.array([5, 10, 250]) / 255, rtol=1e-6)
    np.testing.assert_array_equal(d.X[3], [3, 6, 252, -87.5, 3.0])
    assert sum(s.stop - s.start for s in d.splits.values()) == 12
    assert fetch_light_tunnel(tmp_path, n_samples=5).images.shape[0] == 5
    with pytest.raises(ValueError, match="images_100"):
        fetch_light_tunnel(tmp_path, image_size=64)
    assert set(d.theta_reference) == {"w", "t_p", "t_c"}


def test_light_tunnel_zip_and_missing(tmp_path, monkeypatch):
    src = tmp_path / "src"
    _lt_tree(src, n=3, fmt="jpg")
    zpath = tmp_path / "lt_camera_v1.zip"
    with zipfile.ZipFile(zpath, "w") as z:
        for p in (src / "causal_chamber").rglob("*"):
            z.write(p, p.relative_to(src / "causal_chamber"))
    with pytest.raises(FileNotFoundError, match="lt_camera_v1"):
        fetch_light_tunnel(tmp_path / "home", download_if_missing=False)
    monkeypatch.setattr(cc, "LT_CAMERA", RemoteFile("causal_chamber/lt_camera_v1.zip",
                                                    zpath.as_uri(), _sha(zpath, "md5"), "md5"))
    d = fetch_light_tunnel(tmp_path / "home")
    assert d.images.shape == (3, 3, 100, 100)
    np.testing.assert_allclose(d.images[2].mean(axis=(1, 2)), np.array([2, 4, 253]) / 255,
                               atol=0.02)  # JPEG is lossy


# --------------------------------------------------------------------------------------------
# Simulated stand-ins


def test_wind_tunnel_simulated():
    d = make_wind_tunnel_simulated(random_state=0)
    assert d.simulated and d.DESCR.count("SIMULATED") >= 2
    assert d.X.shape == (985, 200, 3) and d.y.shape == (985, 200)
    assert [(s.start, s.stop) for s in d.splits.values()] == [(0, 600), (600, 750), (750, 985)]
    np.testing.assert_array_equal(d.X[0, :, 2], cc_sim.wind_tunnel_inputs()["hatch"][:200])
    np.testing.assert_array_equal(d.y, make_wind_tunnel_simulated(random_state=0).y)
    dp = d.y - d.pressure_ambient  # bounded by S_max (1 - r) plus noise
    assert np.abs(dp).max() < chamber.S_MAX * (1 - chamber.C3_R0) + 2
    # The stand-in holds what A1+C2 lack (fan lag, hatch): A1+C2 at r = 0.75 misses it by far
    # more than the 0.2 Pa barometer noise.
    ell = np.maximum(d.X[..., :2], chamber.L_MIN) ** 2
    a1c2 = chamber.S_MAX * (1 - chamber.R_CODE) * (ell[..., 0] - ell[..., 1])
    assert np.sqrt(np.mean((dp - a1c2) ** 2)) > 1.0


def test_model_constants():
    assert chamber.S_MAX * (1 - chamber.R_CODE) * (1 - 0.1**2) == pytest.approx(18.519, abs=1e-3)
    assert chamber.FAN_DRAG_K == pytest.approx(5.268701549401565e-08, rel=1e-12)
    assert chamber.hexagon_mask(100).sum() == pytest.approx(3 * 3**0.5 / 2 * 22**2, rel=0.05)


def test_model_f3_colour_matches_formula():
    x = np.array([216, 162, 130]) / 255
    m = (chamber.T_PARALLEL - chamber.T_CROSSED) * np.cos(np.deg2rad(-82.9 + 69.2)) ** 2 + chamber.T_CROSSED
    expected = np.minimum(1, chamber.EXPOSURE_F3 * np.diag(chamber.W_WHITE_BALANCE) @ chamber.S_CAMERA @ x * m)
    got = chamber.model_f3_colour(np.array([[216, 162, 130, -82.9, -69.2]]))[0]
    np.testing.assert_allclose(got, expected, rtol=1e-12)


def test_light_tunnel_simulated():
    d = make_light_tunnel_simulated(n_samples=20, image_size=50, random_state=0)
    assert d.simulated and "SIMULATED" in d.DESCR
    np.testing.assert_array_equal(d.X[:3], [[216, 162, 130, -82.9, -69.2],
                                            [10, 19, 4, -117.0, 112.7],
                                            [165, 232, 128, 38.3, 169.4]])
    assert d.images.shape == (20, 3, 50, 50) and d.images.dtype == np.float32
    assert d.images.min() >= 0 and d.images.max() <= 1
    assert d.images[:, :, 0, 0].max() < 0.05  # dark outside the hexagon
    centre = d.images[:, :, 25, 25]
    f3 = chamber.model_f3_colour(d.X)
    assert np.corrcoef(centre.ravel(), f3.ravel() ** (1 / 2.2))[0, 1] > 0.95
