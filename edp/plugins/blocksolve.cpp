// blockSolve(A, B): B = A⁻¹B for every column of the dense B at once, with the solver set on A
// (set(A, solver = ...)), factorized once as for A^-1*b. FreeFEM's A^-1*b solves one right-hand
// side at a time; CHOLMOD's supernodal solve with many columns works in BLAS-3 and takes a third
// to a quarter of the time per column (docs/model-choices.md, "Contact columns in blocks"). The
// contact set-up uses it for the columns of K⁻¹Cᵀ (edp/lib/contact.idp). Compiled by ff-c++ (Debian
// package libfreefem++-dev) into this folder by `make setup` (bin/plugins); loaded by
// `load "blocksolve"` from FF_LOADPATH, which bin/ff and orchestrate set.
#include <climits>
#include "ff++.hpp"

static long blockSolve(Matrice_Creuse<double>* const& matrix, KNM<double>* const& columns) {
  VirtualMatrix<int, double>* A = matrix->A;
  KNM<double>& B = *columns;
  if (!A || !A->WithSolver()) ExecError("blockSolve: the matrix has no solver (set(A, solver = ...) first)");
  if (A->n != A->m || A->n != B.N())
    ExecError("blockSolve: the right-hand sides have a different number of rows than the square matrix");
  if (B.M() == 0) return 0;
  if (static_cast<long>(B.N())*B.M() > INT_MAX)  // FreeFEM's CHOLMOD and UMFPACK wrappers index in int
    ExecError("blockSolve: a block of more than 2^31 - 1 numbers; solve fewer columns at a time");
  ffassert(B.IsVector1());  // one contiguous column-major block, as the solver reads it
  KNM<double> X(B.N(), B.M());
  A->solve(&X(0, 0), &B(0, 0), B.M(), 0);
  B = X;
  return B.M();
}

static void init() {
  Global.Add("blockSolve", "(", new OneOperator2_<long, Matrice_Creuse<double>*, KNM<double>*>(blockSolve));
}

LOADFUNC(init)
