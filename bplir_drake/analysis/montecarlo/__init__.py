"""Monte Carlo robustness studies and the controller benchmark.

* :mod:`.study` -- a study's schema, distributions and TOML file;
* :mod:`.sampling` -- each sample's draws, seed and parameters, and running
  it into a result row;
* :mod:`.store` -- the results CSV of a study directory;
* :mod:`.executors` -- process pool and Dask;
* :mod:`.statistics` -- success rate (Wilson interval), outcomes,
  percentiles, influence;
* :mod:`.runner` -- running and resuming a study directory, replaying a
  sample (the module docstring describes a study file);
* :mod:`.benchmark` -- scoring controller presets by category;
* :mod:`.plots` -- plots of a study's rows.
"""
from .executors import map_jobs
from .runner import StudyResult, prepare_out, replay, run_study
from .sampling import (apply_values, base_value, draw_values, error_text, pinned, run_sample,
                       sample_params, sample_seed)
from .statistics import PERCENTILE_FIELDS, influence, summarize, wilson_interval
from .store import ResultWriter, columns, read_results
from .study import (DIST_KINDS, RESULT_FIELDS, RESULTS_FILE, STUDY_FILE, SUMMARY_FILE,
                    UNCERTAIN_BLOCKS, Distribution, Study, StudyError, StudyRow,
                    dissertation_distributions,
                    load_study, save_study, study_from_dict)

__all__ = ["StudyResult", "map_jobs", "prepare_out", "replay", "run_study", "apply_values", "base_value",
           "draw_values", "error_text", "pinned", "run_sample", "sample_params", "sample_seed",
           "PERCENTILE_FIELDS", "influence", "summarize", "wilson_interval", "ResultWriter",
           "columns", "read_results", "DIST_KINDS", "RESULT_FIELDS", "RESULTS_FILE", "STUDY_FILE",
           "SUMMARY_FILE", "UNCERTAIN_BLOCKS", "Distribution", "Study", "StudyError", "StudyRow",
           "dissertation_distributions", "load_study", "save_study", "study_from_dict"]
