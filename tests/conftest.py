import sys
from pathlib import Path

import pytest

# Make tests/strategies.py importable as `strategies` from every test folder.
sys.path.insert(0, str(Path(__file__).parent))


@pytest.fixture(scope="session")
def tiny_corpus(tmp_path_factory):
    """A rendered corpus of one design at two stations, small and quick (wall-door)."""
    from unseeable.corpus.build import build_corpus
    from unseeable.render.settings import RenderSettings

    root = tmp_path_factory.mktemp("corpus")
    build_corpus(root, angles=(120, 150), size=(320, 240), settings=RenderSettings(spp=4),
                 only=["wall-door"], workers=1)
    return root


@pytest.fixture(scope="session")
def tower_corpus(tmp_path_factory):
    """tower-3 and its removal subset tower-3-L3 at two stations, small and quick: the
    smallest corpus active vision's disassembly actions can be taken on."""
    from unseeable.corpus.build import build_corpus
    from unseeable.render.settings import RenderSettings

    root = tmp_path_factory.mktemp("towers")
    build_corpus(root, angles=(120, 150), size=(320, 240), settings=RenderSettings(spp=4),
                 only=["tower-3", "tower-3-L3"], workers=1)
    return root
