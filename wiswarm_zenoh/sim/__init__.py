"""The simulator shell: the core's leader and followers in virtual time over a model of
a shared wireless channel (slotted, or 802.11 with CSMA/CA), against push baselines."""
