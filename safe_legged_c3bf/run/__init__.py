"""Running the node graph: plan, session, supervision, monitoring, recording and run reports.

``safe_legged_c3bf.bringup`` is the command line entry point; the modules here are its parts:

- the run plan: :mod:`.plan` (scenario loaded once, run folder, node specs), :mod:`.parameters`
  (every parameter layer, merged in one place), :mod:`.graph` (node names, modules, order);
- the session: :mod:`.session` (start, watch, stop) runs the nodes through a
  :mod:`.launcher` — :mod:`.processes` (one supervised process each, :mod:`.supervisor`,
  :mod:`.process_group`, :mod:`.child`) or :mod:`.in_process` — and :mod:`.ending` reports;
  :mod:`.outcome` holds how a run ends and the exit codes;
- the console: :mod:`.console` (progress line, stop requests by signal) and
  :mod:`.quiet_stderr` (C-level stderr redirection);
- :mod:`.monitor` is the bringup's own node that watches the run and keeps its time series;
- :mod:`.report` turns those into ``report.json`` and a printed summary, :mod:`.plots` into
  plots (on :mod:`.figure`, shared with the evaluation's figures);
- :mod:`.recorder` writes an MCAP file of the contract topics, with message definitions from
  :mod:`.msgdefs`.
"""
