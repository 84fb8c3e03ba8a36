"""Sparse linear algebra of the block interior-point method: the method itself, its Cholesky and kernels.

* :mod:`.block_ipm`         the block interior-point LP method (Mehrotra with Gondzio correctors);
* :mod:`.cholesky`          the supernodal multifrontal Cholesky (one or two processes) and SuperLU's LDL^T;
* :mod:`.cholesky_kernels`, :mod:`.block_kernels`  their optional compiled loops (numba);
* :mod:`.null_space`        a sparse null-space basis of equality rows;
* :mod:`.cpus`              how many CPUs the automatic settings may use.

Imports only numpy, scipy, numba, pymetis and threadpoolctl, never another blockmpec module: the engines above
hand it matrices and map its outcomes (:class:`.block_ipm.IPMOutcome`) to the library's statuses.
"""
