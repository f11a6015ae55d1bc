"""The core, grouped by job; it imports nothing above it (no builtin plugin, diagnosis, report, CLI
or backend: tests/unit/test_layering.py).

* :mod:`~calibrax.core.sheartest`: the shear test (spec, presets, stages, physics, peaks, result,
  yield locus) and the analytic references and checks of the contact law;
* :mod:`~calibrax.core.data`: experiments, the features read off tests and experiments,
  pseudo-experiments;
* :mod:`~calibrax.core.search`: parameters, designs, Kriging models, acquisitions, metrics, noise
  thresholds, the answer;
* :mod:`~calibrax.core.running`: the scheduler, the executors, the isolated simulation process,
  the store;
* :mod:`~calibrax.core.studies`: the campaign, crosschecks, convergence studies;
* at the top: the config (:mod:`~calibrax.core.config`), the Simulator interface, the hook specs
  and the plugin registry, the YAML reader.
"""
