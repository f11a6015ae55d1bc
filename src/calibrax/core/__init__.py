"""The core, grouped by job; it imports nothing above it (no builtin plugin, diagnosis, report, CLI
or backend), and its parts form a strict stack without import cycles, each importing only from
those below it (tests/unit/test_layering.py, ``STACK``). Lowest first:

* :mod:`~calibrax.core.yamlfile`: the YAML reader;
* :mod:`~calibrax.core.hookspecs`, :mod:`~calibrax.core.registry`: the hook specs and the plugin
  registry;
* :mod:`~calibrax.core.sheartest`: the shear test (spec, presets, stages, physics, peaks, steps,
  result, yield locus) and the analytic references and checks of the contact law;
* :mod:`~calibrax.core.simulator`: the Simulator interface;
* :mod:`~calibrax.core.data`: experiments, the features read off tests and experiments,
  pseudo-experiments;
* :mod:`~calibrax.core.search`: parameters, designs, the point records, Kriging models,
  acquisitions, metrics, noise thresholds, the answer;
* :mod:`~calibrax.core.running`: the scheduler, the executors, the isolated simulation process,
  the store;
* :mod:`~calibrax.core.fidelities`: a multi-fidelity campaign's presets, and the campaign's
  fidelity plan (one fidelity or several: which one each point runs at);
* :mod:`~calibrax.core.resolved`, :mod:`~calibrax.core.warm_start`: the resolved config's added
  fields, and a store started from an earlier one;
* :mod:`~calibrax.core.config`: the campaign config;
* :mod:`~calibrax.core.studies`: the campaign, crosschecks, convergence studies.
"""
