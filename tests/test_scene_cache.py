"""Scenes loaded from dicts are kept by content (lsc.scene._cache): the same content gives the
Scene already validated; any other content, value type, folder or file gives its own."""

import pytest

import lsc
from helpers import two_cars
from lsc.model import HybridModel


def _scene(speed=2.0, **contact):
    return two_cars(1200.0, 1500.0, speed, 0.0, {"stiffness": 1.0e6}, {"restitution": 0.4},
                    **contact)


def test_the_same_content_loads_the_same_scene_and_other_content_its_own():
    first = lsc.Scene.load(_scene())
    assert lsc.Scene.load(_scene()) is first          # an equal dict, built anew
    faster = lsc.Scene.load(_scene(speed=3.0))
    assert faster is not first and faster.vehicles[0].speed == 3.0
    assert first.vehicles[0].speed == 2.0


def test_a_dict_changed_in_place_is_loaded_again():
    d = _scene()
    first = lsc.Scene.load(d)
    d["contacts"][0]["unloading"]["restitution"] = 0.8
    again = lsc.Scene.load(d)
    assert again is not first
    assert again.contacts[0].law.unloading.e == 0.8
    assert first.contacts[0].law.unloading.e == 0.4


def test_a_value_of_another_type_is_validated_again():
    """``0`` and ``False`` are equal in Python, and only one of them is a speed."""
    lsc.Scene.load(_scene(speed=1))
    d = _scene(speed=1)
    d["vehicles"][1]["speed"] = False
    with pytest.raises(lsc.SceneError) as ei:
        lsc.Scene.load(d)
    assert ei.value.path == "vehicles[1].speed"
    assert "the boolean false is not a quantity" in ei.value.message
    # (and an error is raised again on the next load: nothing is kept of a failed one)
    with pytest.raises(lsc.SceneError):
        lsc.Scene.load(d)


def test_another_folder_gives_another_scene(tmp_path):
    here = lsc.Scene.load(_scene(), base_dir=tmp_path)
    there = lsc.Scene.load(_scene(), base_dir=tmp_path / "other")
    assert here.base_dir == tmp_path and there.base_dir == tmp_path / "other"


def test_a_table_read_from_a_file_is_read_again(tmp_path):
    """A scene naming a CSV file is not kept: the file may have changed between two loads."""
    (tmp_path / "edge.csv").write_text("d,f\n0,0\n0.1,1000\n")
    d = two_cars(1200.0, 1500.0, 2.0, 0.0, {"csv": "edge.csv"}, {"restitution": 0.4})
    soft = lsc.Scene.load(d, base_dir=tmp_path)
    (tmp_path / "edge.csv").write_text("d,f\n0,0\n0.1,5000\n")
    stiff = lsc.Scene.load(d, base_dir=tmp_path)
    assert soft.contacts[0].law.loading.f[-1] == 1000.0
    assert stiff.contacts[0].law.loading.f[-1] == 5000.0


def test_solving_a_dict_again_builds_its_model_anew(monkeypatch):
    """The kept Scene's model is not: what a solve computes lazily on its model is never shared
    by the next solve of a dict (a kept scene, solved by any backend, gives the same numbers)."""
    built = []
    monkeypatch.setattr(lsc.api, "HybridModel", lambda s: built.append(s) or HybridModel(s))
    a, b = lsc.solve(_scene()), lsc.solve(_scene())
    assert len(built) == 2 and built[0] is built[1]
    assert (a.delta_v == b.delta_v).all() and (a.peak_force == b.peak_force).all()


def test_a_scene_kept_before_its_law_was_unregistered_is_refused_after():
    """A dict naming a registered law, kept, is loaded again once the law is unregistered (and
    refused), not returned from the cache: the key includes the registered laws (the toy law
    of tests/test_extending.py, registered by one test and unregistered before the next,
    was found by that file's order)."""
    from test_extending import QuadraticDampingLaw, toy_scene
    from lsc.laws import register_law, unregister_law

    register_law(QuadraticDampingLaw)
    try:
        lsc.Scene.load(toy_scene())
    finally:
        unregister_law("toy")
    with pytest.raises(lsc.SceneError, match='unknown contact law "toy"'):
        lsc.Scene.load(toy_scene())
