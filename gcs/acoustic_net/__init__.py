"""The GCS's side of the acoustic room (acoustic/) in a mission: the network composed on the mission
clock (network.py), the GCS's end of it (uplink.py: the reports heard; call_ups.py: the call-ups sent in
the aPads' slots) and what the planner believes of an aMussel it hears now and then (knowledge.py). It
imports nothing of `gcs.mission`, which composes it (world.py); what a scenario means to the channel is
`gcs.scenario.tdma_frame`."""
