"""The boxes of seed 000 Fig. 2 (attitude determination flowchart), one module each, in the order of an epoch:

    propagate -> quality_control -> measurement_update -> ambiguity_resolution (-> validation) -> fix_monitor
    -> output

Each box is a function of (run: FilterRun, ep: EpochData) that reads and writes the filter's state
(gnssatt.attitude.filter_state); gnssatt.attitude.filter.run_filter calls them in turn per epoch.
"""
