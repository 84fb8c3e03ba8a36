"""Numerical engines shared by the methods: not methods themselves, never registered.

* :mod:`.highs`          the one HiGHS wrapper (persistent LP/MILP, one status map);
* :mod:`.block_ipm`      the block interior-point LP method for large static LPs;
* :mod:`.scaling`        load units for the LPs (rows per block load, forces per interface load);
* :mod:`.lp_sequence`    the persistent sequence of modified associative LPs (fixed point, SLP);
* :mod:`.newton_system`  the Fischer-Burmeister system of the MCP (3) for ``mcp-newton``.

Backends (highspy, cyipopt) are imported inside functions, never at module import.
"""
