"""What people read: figures, the comparison report and the tuning guide, written atomically (``pipeline/atomic.py``).

``figures`` (a Figure to PNG / SVG bytes), ``style``
(engine colours), ``timeseries`` (y(t) of a comparison), ``comparison_files`` (everything
``compare --out`` writes), ``sweep_data`` / ``work_precision`` (its points: ``work_precision_points``) / ``stability_map`` (a sweep's
charts), ``plate_map_figure``, ``report`` / ``report_page`` (the report and its HTML and
Markdown), ``guide`` (the tuning guide; its answer's sentences: ``guide_answer``). Charts are built as ``matplotlib.figure.Figure``
without pyplot: importing them leaves the user's backend alone.
"""
