"""Reports: the paper's four experiments (MODEL 10) from one results store, or two scenes side by
side, as tables (CSV, markdown), figures (PNG) and a templated reading; and the picture of one map.

    build.py         the report of one store: `build_report` (its files, `report.md`, `report.json`)
    caging.py        experiment 1, the best caging design of every part
    tip.py           experiment 2, caging versus tip prehension, representative designs
    manipulation.py  experiment 3, in-hand manipulation, Scenario A against Scenario B
    usage.py         experiment 4, parameter usage under Scenario B
    compare.py       two scenes side by side: `build_comparison`, the tables of both scenes
    stores.py        opening a store for a report (`open_store`), or two comparable ones
    accuracy.py      the accuracy study's report (`sweep accuracy`, `sweep.runs.accuracy`)
    data.py          the store as the report reads it (`StoreData`), rankings, number format
    style.py         the figure style: PNG rendering, colours, the unitless note
    plot.py          the picture of one map (`plot_map`, `draw_map_panel`; `sweep map --plot`)

Each experiment module holds its table rows, its figure, its two-scene figure (`pair_figure`)
and its reading, and imports no other experiment; every number comes from
the store or from maps recomputed with the store's own settings.
"""
