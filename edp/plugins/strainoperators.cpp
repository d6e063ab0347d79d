// Two of a body's strain operators (edp/lib/body.idp, bodyForms) built from the ones FreeFEM's
// interpolate made, in one pass over their entries instead of two more interpolates, a sum, a
// transpose and a product of sparse matrices (a third of the set-up of a body's forms):
//   shearOperator(Dx, Dy, G12)         G12 = ∂y of the x-component + ∂x of the y-component, from
//                                      Dx = ∂x of the x-component and Dy = ∂y of the y-component
//                                      (P0 × [P1, P1], dofs interleaved x, y per vertex)
//   weightedTranspose(D, w, DW)        DW = Dᵀ diag(w)
// Each entry is an entry of D times one weight, or an entry moved: the values are those of the
// interpolate and of FreeFEM's own products to the bit. So are the products with the matrices,
// because the entries of each row are stored in the order FreeFEM's operations leave them: G12's
// row of a triangle holds its ∂y entries before its ∂x ones (FreeFEM's A + B: A's, then B's), and
// DW's rows hold their triangles in increasing order (FreeFEM's transpose and product). A
// matrix-vector product sums each row in that order (tests/test_strain_operators.py).
#include <vector>
#include "ff++.hpp"
#include "AFunction_ext.hpp"

typedef HashMatrix<int, double> Entries;

static Entries& entriesOf(Matrice_Creuse<double>* const& matrix, const char* who) {
  Entries* A = matrix->pHM();
  if (!A || A->half || A->fortran) ExecError(std::string(who) + ": a general sparse matrix is needed");
  return *A;
}

// target = the n × m matrix of the given entries, stored in their order
static void store(Matrice_Creuse<double>* const& target, int n, int m, std::vector<int>& row, std::vector<int>& column,
                  std::vector<double>& value) {
  Entries* A = new Entries(n, m, 0, 0);
  A->set(n, m, 0, value.size(), row.data(), column.data(), value.data(), 0, 0);
  target->A.master(A);
  target->typemat = 0;
}

static long shearOperator(Matrice_Creuse<double>* const& dx, Matrice_Creuse<double>* const& dy,
                          Matrice_Creuse<double>* const& g12) {
  const Entries &Dx = entriesOf(dx, "shearOperator"), &Dy = entriesOf(dy, "shearOperator");
  if (Dx.n != Dy.n || Dx.m != Dy.m || Dx.m % 2) ExecError("shearOperator: Dx and Dy are not P0 × [P1, P1] operators of one mesh");
  std::vector<int> row, column;
  std::vector<double> value;
  row.reserve(Dx.nnz + Dy.nnz); column.reserve(Dx.nnz + Dy.nnz); value.reserve(Dx.nnz + Dy.nnz);
  // (triangle, dof of the y-component) of Dy → (triangle, dof of the x-component), and back for Dx
  for (size_t k = 0; k < Dy.nnz; k++) {
    if (Dy.j[k] % 2 != 1) ExecError("shearOperator: Dy has an entry on an x-component dof");
    row.push_back(Dy.i[k]); column.push_back(Dy.j[k] - 1); value.push_back(Dy.aij[k]);
  }
  for (size_t k = 0; k < Dx.nnz; k++) {
    if (Dx.j[k] % 2 != 0) ExecError("shearOperator: Dx has an entry on a y-component dof");
    row.push_back(Dx.i[k]); column.push_back(Dx.j[k] + 1); value.push_back(Dx.aij[k]);
  }
  store(g12, Dx.n, Dx.m, row, column, value);
  return 0;
}

static long weightedTranspose(Matrice_Creuse<double>* const& d, KN<double>* const& weight, Matrice_Creuse<double>* const& dw) {
  const Entries& D = entriesOf(d, "weightedTranspose");
  if (weight->N() != D.n) ExecError("weightedTranspose: one weight per row of D is needed");
  // the entries by row of Dᵀ (column of D), each row's in increasing column of Dᵀ: a counting
  // sort by D's row, then a stable one by D's column
  std::vector<size_t> byRow(D.nnz), order(D.nnz);
  std::vector<size_t> start(std::max(D.n, D.m) + 1);
  auto bucket = [&](const int* key, int keys, const std::vector<size_t>& from, std::vector<size_t>& to) {
    std::fill(start.begin(), start.end(), 0);
    for (size_t k = 0; k < D.nnz; k++) start[key[k] + 1]++;
    for (int b = 0; b < keys; b++) start[b + 1] += start[b];
    for (size_t k : from) to[start[key[k]]++] = k;
  };
  std::vector<size_t> stored(D.nnz);
  for (size_t k = 0; k < D.nnz; k++) stored[k] = k;
  bucket(D.i, D.n, stored, byRow);
  bucket(D.j, D.m, byRow, order);
  std::vector<int> row(D.nnz), column(D.nnz);
  std::vector<double> value(D.nnz);
  for (size_t at = 0; at < D.nnz; at++) {
    const size_t k = order[at];
    row[at] = D.j[k]; column[at] = D.i[k]; value[at] = D.aij[k]*(*weight)[D.i[k]];
  }
  store(dw, D.m, D.n, row, column, value);
  return 0;
}

static void init() {
  Global.Add("shearOperator", "(", new OneOperator3_<long, Matrice_Creuse<double>*, Matrice_Creuse<double>*,
                                                     Matrice_Creuse<double>*>(shearOperator));
  Global.Add("weightedTranspose", "(", new OneOperator3_<long, Matrice_Creuse<double>*, KN<double>*,
                                                         Matrice_Creuse<double>*>(weightedTranspose));
}

LOADFUNC(init)
