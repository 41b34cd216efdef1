"""The disk cache of certified scenes: exact round trip, corrupt entries ignored, keys."""
from compass_manip.sim import scene_cache
from compass_manip.sim.certify import CertFailure, Certificate, CertifyConfig, regenerate


def _certificate():
    return Certificate(failure=None, start_visibility=0.01, fv_solvable=True, grasp_approach_deg=15.0,
                       lift_height=0.034, n_objects=11, path=((0.1,) * 7, (0.2,) * 7), path_marks=(1,),
                       stage_times_s=(("views", 1.5),), time_s=2.0)


def test_entry_round_trips_exactly(tmp_path):
    scene = regenerate((0, 2, 3, 0))
    path = str(tmp_path / "e.json")
    scene_cache.store(path, scene, _certificate(), 4, ["NO_GRASP"])
    got = scene_cache.load(path, Certificate, CertFailure)
    assert got == (scene, _certificate(), 4, ("NO_GRASP",))


def test_corrupt_or_missing_entry_is_a_miss(tmp_path):
    path = tmp_path / "e.json"
    assert scene_cache.load(str(path), Certificate, CertFailure) is None
    path.write_text('{"scene": {"level": 1}')
    assert scene_cache.load(str(path), Certificate, CertFailure) is None


def test_key_names_level_index_seed_and_config(tmp_path, monkeypatch):
    monkeypatch.setenv("COMPASS_CACHE_DIR", str(tmp_path))
    a = scene_cache.entry_path(1, 0, 0, CertifyConfig())
    assert a.startswith(str(tmp_path)) and a != scene_cache.entry_path(1, 0, 1, CertifyConfig())
    assert a != scene_cache.entry_path(1, 1, 0, CertifyConfig())
    assert a != scene_cache.entry_path(1, 0, 0, CertifyConfig(min_view_visibility=0.4))
    assert a == scene_cache.entry_path(1, 0, 0, CertifyConfig())
