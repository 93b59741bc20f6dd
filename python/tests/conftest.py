"""Shared test helpers: the repository's fixtures and the `spherefit` CLI to compare with."""

import json
import os
import subprocess
from pathlib import Path

import geopandas as gpd
import pytest

ROOT = Path(__file__).resolve().parents[2]
FIXTURES = ROOT / "fixtures"


def cli_binary() -> Path:
    """The CLI built from this checkout (SPHEREFIT_BIN, else target/release/spherefit)."""
    p = Path(os.environ.get("SPHEREFIT_BIN", ROOT / "target" / "release" / "spherefit"))
    if not p.exists():
        raise RuntimeError(f"{p} is missing: run `cargo build --release` (or set SPHEREFIT_BIN)")
    return p


def run_cli(*args, stdin=None):
    """Runs the CLI and returns its JSON output."""
    r = subprocess.run(
        [str(cli_binary()), *map(str, args)],
        input=stdin,
        capture_output=True,
        text=True,
        check=False,
    )
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout)


def features(path: Path):
    """The features of a GeoJSON document or text sequence, in order."""
    text = path.read_text()
    if text.startswith("\x1e"):
        return [json.loads(rec) for rec in text.split("\x1e") if rec.strip()]
    return json.loads(text)["features"]


def frame(path: Path) -> gpd.GeoDataFrame:
    """A GeoDataFrame (EPSG:4326) of the fixture's features."""
    return gpd.GeoDataFrame.from_features(features(path), crs="EPSG:4326")


@pytest.fixture
def border():
    return frame(FIXTURES / "us_mexico_border_natural_earth.geojson")


@pytest.fixture
def tracks():
    return frame(FIXTURES / "gps_tracks_slovenia_gpxpy.geojson")


@pytest.fixture
def batch():
    """Antimeridian with altitude, a Point, a MultiLineString, a Polygon and a pole."""
    return frame(FIXTURES / "batch_tracks.geojsons")
