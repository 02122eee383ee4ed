"""A campaign: its file (``campaign_file``, with the commented ``templates`` of
``ogacq init``), the station that opens its endpoints (``station``), what it records
about itself (``traceability``, the gauges met before in ``inventory``) and the run
end to end (``run``: station + runner + session + identification)."""
