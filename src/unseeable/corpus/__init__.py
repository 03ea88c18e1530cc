"""The evaluation corpus: 32 designed structures, their placements and their renders.

Like the paper's (5 views of each of 32 structures), the corpus holds cabins
with doors and windows, plain walls, towers, L- and U-shapes and structures
hiding logs behind walls, designed so that proper-subset relations hold
between pairs (layer truncations, an inner wall taken out) for the simulated
partial disassembly. The designs are code (:mod:`unseeable.corpus.designs`);
the shipped JSON files in ``unseeable/data/corpus/`` are generated from it.

Examples
--------
>>> entry = load_design("cabin-door-L3")
>>> entry.subset_of
('cabin-door',)
"""

from unseeable.corpus.build import (
    BuildReport,
    Corpus,
    CorpusItem,
    CorpusView,
    build_corpus,
    load_corpus,
)
from unseeable.corpus.designs_index import CorpusEntry, design_names, list_designs, load_design
from unseeable.corpus.relations import is_proper_subset, physical_logs, truncation_layer

__all__ = [
    "CorpusEntry",
    "list_designs",
    "load_design",
    "design_names",
    "is_proper_subset",
    "physical_logs",
    "truncation_layer",
    "build_corpus",
    "load_corpus",
    "Corpus",
    "CorpusItem",
    "CorpusView",
    "BuildReport",
]
