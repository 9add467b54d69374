"""The paper's comparison, reproduced: Table 2 and 3 analogs, references, figures, reports.

Pure numpy below the reports (no rclpy). ``scara-ident compare`` feeds it simulated data,
``scara-ident tables`` a recorded bag; both produce the same rows and tables. One module per
concept, each importing only those above it in this list (the path bag → report goes one
way):

=====================  ===============================================================
``datasets``           simulated runs as records or samples; ``Evaluations``
``rows``               ``ResultRow`` (one model on one data set), ``summarise`` over seeds
``tables``             rows to Markdown and CSV, the paper's numbers beside ours
``hyperparameters``    the per-method grid search of online-learning settings
``table2``             Table 2 analog: Levenberg–Marquardt from several seeds
``table3``             Table 3 analog: per-sample learning over a stream
``reference``          the model-based least-squares rows
``retraining``         Table 2 from a recorded run: methods × seeds, one validation split
``online_results``     identifiers' published predictions paired with measurements
``learning_curves``    held-out NMSE against streamed time, networks and references
``contact``            contact-detection benchmark helpers on simulated pulses
``figures``            Figures 6–15 and the learning curves as PNG files
``software_versions``  the versions a report records
``comparison``         ``scara-ident compare``: the report on simulated data
``report``             ``scara-ident tables``: the report on a recorded run
=====================  ===============================================================

Samples, the validation split and recordings are the identification's
(:mod:`scara_ident_ros.identification.dataset`, ``.split``, ``.recording``); the NMSE is
:mod:`scara_ident_ros.identification.metrics`.
"""
