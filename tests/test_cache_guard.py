"""The per-module invalidation of the core's Numba cache (``edmd._core.guard_cache``)."""

from edmd._core import fingerprints, guard_cache

SOURCES = {
    "loop": "from .collide import rule\nfrom .queue import top\n",
    "collide": "from .predict import flight\nrule = 1\n",
    "predict": "flight = 1\n",
    "queue": "top = 1\n",
}


def test_a_change_reaches_every_module_that_depends_on_it():
    before = fingerprints(SOURCES)
    after = fingerprints({**SOURCES, "predict": "flight = 2\n"})
    changed = {name for name in SOURCES if before[name] != after[name]}
    assert changed == {"predict", "collide", "loop"}  # queue does not import predict


def _package(tmp_path, sources):
    for name, text in sources.items():
        (tmp_path / f"{name}.py").write_text(text)
    cache = tmp_path / "__pycache__"
    cache.mkdir(exist_ok=True)
    for name in sources:
        (cache / f"{name}.f-1.py311.nbi").write_text("index")
        (cache / f"{name}.f-1.py311.1.nbc").write_text("code")
    return cache


def test_only_the_stale_modules_lose_their_cache(tmp_path):
    cache = _package(tmp_path, SOURCES)
    guard_cache(tmp_path, cache)  # first call: no stamp yet, every file is suspect
    assert not list(cache.glob("*.nb[ic]"))
    _package(tmp_path, SOURCES)
    guard_cache(tmp_path, cache)  # unchanged sources: the cache stays
    assert len(list(cache.glob("*.nb[ic]"))) == 8
    (tmp_path / "collide.py").write_text("from .predict import flight\nrule = 2\n")
    guard_cache(tmp_path, cache)
    left = sorted({p.name.split(".")[0] for p in cache.glob("*.nb[ic]")})
    assert left == ["predict", "queue"]


def test_the_cache_folder_is_cleaned_and_a_new_one_stamped(tmp_path):
    # NUMBA_CACHE_DIR (clusters, CI): the cache lives in a folder of its own
    _package(tmp_path, SOURCES)
    elsewhere = tmp_path / "numba-cache" / "core_1234"
    guard_cache(tmp_path, elsewhere)  # not there yet: created with the fingerprints
    for name in SOURCES:  # what Numba then caches in this process is current
        (elsewhere / f"{name}.f-1.py311.nbi").write_text("index")
    guard_cache(tmp_path, elsewhere)  # the next import keeps it all (a warm start)
    assert len(list(elsewhere.glob("*.nbi"))) == 4
    (tmp_path / "queue.py").write_text("top = 2\n")
    guard_cache(tmp_path, elsewhere)
    assert sorted(p.name.split(".")[0] for p in elsewhere.glob("*.nbi")) == ["collide", "predict"]


def test_the_cache_folder_follows_numba(monkeypatch, tmp_path):
    from numba.core import config

    from edmd._core import cache_folder

    (tmp_path / "pkg").mkdir()
    monkeypatch.setattr(config, "CACHE_DIR", "")
    assert cache_folder(tmp_path / "pkg") == tmp_path / "pkg" / "__pycache__"
    monkeypatch.setattr(config, "CACHE_DIR", str(tmp_path / "cache"))
    folder = cache_folder(tmp_path / "pkg")
    assert folder.parent == tmp_path / "cache" and folder.name.startswith("pkg_")


def test_the_stamp_is_replaced_whole(tmp_path):
    # processes importing edmd together (pytest-xdist workers, a sweep's pool) read the stamp
    # while one of them writes it: a reader must see the old stamp or the new one, never a part
    cache = _package(tmp_path, SOURCES)
    guard_cache(tmp_path, cache)
    stamp = cache / "edmd-core-sources.json"
    with stamp.open() as reader:  # a reader of the old stamp
        (tmp_path / "queue.py").write_text("top = 2\n")
        guard_cache(tmp_path, cache)
        assert reader.read() != stamp.read_text()  # it still reads the old one whole (not truncated in place)
    assert [p.name for p in cache.iterdir() if p.suffix not in (".nbi", ".nbc")] == ["edmd-core-sources.json"]  # no leftover
