// The two halves of a CHOLMOD solve, on the factorization FreeFEM made for K (set(K, solver =
// CHOLMOD), factorized): K = Pᵀ L D Lᵀ P (D = I for CHOLMOD's supernodal LLᵀ), so
//   K⁻¹b = factorBackward(K, factorForward(K, b)),  forward: D⁻¹ L⁻¹ P b,  backward: Pᵀ L⁻ᵀ x,
// to the bit what K^-1*b gives (CHOLMOD's own solve runs the same steps). The contact problem is
// condensed with them (edp/lib/contact.idp, condensation = factor): with Y = L⁻¹ P Cᵀ and
// Ŷ = D⁻¹ Y, S = C K⁻¹ Cᵀ = Yᵀ Ŷ, C K⁻¹ F = Yᵀ forward(F) and K⁻¹(F − Cᵀλ) =
// backward(forward(F) − Ŷ λ): a step costs one solve, and Y is sparse (L⁻¹ of a column with a
// few nonzeros reaches only the rows of its elimination-tree path), where K⁻¹Cᵀ is dense.
//   factorComplete(K)                           false when CHOLMOD's factor has a pivot that is not
//                                               positive (K not SPD in double precision); true
//                                               for a positive factor or another solver
//   factorForward(K, x), factorBackward(K, x)   in place, x a real[int] of K's size
//   int Y = factorColumns(K, Ct, S, block)      Y and Ŷ, kept here (Y names them), and S
//                                               (real[int,int]) from the sparse n × m Cᵀ, block
//                                               columns per solve
//   addTransposedProduct(Y, z, y), subtractProduct(Y, lambda, u)   y += Yᵀz, u −= Ŷλ
//   columnNonzeros(Y)                           Y's nonzeros (run.json factorColumnNonzeros1, 2)
//   forgetColumns(Y)                            frees Y and Ŷ (K factorized again for another
//                                               k: edp/lib/start.idp); Y names nothing after it
// The plugin keeps Y by columns (an int row index and a double a nonzero; Ŷ only where D ≠ I,
// CHOLMOD's simplicial LDLᵀ of small matrices): a step reads all of Y once and the columns of
// Ŷ of the active nodes once, where FreeFEM's matrices would hold both with two indices a
// nonzero.
// Needs FreeFEM's CHOLMOD solver object (VirtualSolverSparseSuite.hpp, with the SuiteSparse
// headers of Debian's libsuitesparse-dev). Compiled by `make setup` (bin/plugins), loaded by
// `load "factorsplit"` from FF_LOADPATH.
#include <algorithm>
#include <climits>
#include <memory>
#include <vector>
#define HAVE_LIBUMFPACK 1
#define HAVE_SUITESPARSE_UMFPACK_H 1
#include "ff++.hpp"
#include "AFunction_ext.hpp"
#include "VirtualSolverSparseSuite.hpp"

typedef VirtualSolverCHOLMOD<int, double> Cholmod;

static Cholmod* solverOf(Matrice_Creuse<double>* const& matrix) {
  VirtualMatrix<int, double>* A = matrix->A;
  Cholmod* solver = A && A->WithSolver() ? dynamic_cast<Cholmod*>(A->vsolver) : 0;
  // FreeFEM's class as these headers lay it out: a factor that does not read back as this
  // matrix's would mean other SuiteSparse headers than FreeFem++ was built with
  if (solver && solver->L && (solver->L->n != static_cast<size_t>(solver->n) || solver->L->itype != CHOLMOD_INT
                              || solver->L->xtype != CHOLMOD_REAL || solver->L->dtype != CHOLMOD_DOUBLE))
    ExecError("factorsplit: CHOLMOD's factor does not read back as FreeFEM's: rebuild the plugin (make setup)");
  return solver;
}

// Whether CHOLMOD's factorization is complete with positive pivots: its supernodal LLᵀ stops at
// the first pivot ≤ 0 (L->minor < n); its simplicial LDLᵀ stops only at a zero one, so D is read.
static bool positiveFactor(const cholmod_factor* L) {
  if (L->minor < L->n) return false;
  if (L->is_ll || L->is_super) return true;
  const int* p = static_cast<int*>(L->p);
  const double* x = static_cast<double*>(L->x);
  for (size_t j = 0; j < L->n; j++)
    if (!(x[p[j]] > 0)) return false;
  return true;
}

static Cholmod* factorOf(Matrice_Creuse<double>* const& matrix, const char* who) {
  Cholmod* solver = solverOf(matrix);
  if (!solver) ExecError(std::string(who) + ": the matrix has no CHOLMOD solver (set(A, solver = \"CHOLMOD\"))");
  if (!solver->L || !positiveFactor(solver->L))
    ExecError(std::string(who) + ": the matrix is not factorized, or not positive definite (solve with it once first)");
  return solver;
}

// X = steps applied in turn to the n × columns block at x (column-major), in place. The steps
// alternate between x and a work block kept from call to call (a step's two halves then copy
// nothing).
static void apply(Cholmod* solver, std::initializer_list<int> steps, double* x, int columns) {
  static std::vector<double> work;
  work.resize(std::max(work.size(), static_cast<size_t>(solver->n)*columns));
  double *from = x, *to = work.data();
  for (int system : steps) {
    cholmod_dense in, out, *result = &out;
    solver->set_cholmod_dense(in, from, columns);
    solver->set_cholmod_dense(out, to, columns);
    if (!cholmod_solve2(system, solver->L, &in, NULL, &result, NULL, &solver->Ywork, &solver->Ework, &solver->c)
        || result != &out)
      ExecError("factorsplit: CHOLMOD's solve failed");
    std::swap(from, to);
  }
  if (from != x) std::copy(from, from + static_cast<size_t>(solver->n)*columns, x);
}

static bool factorComplete(Matrice_Creuse<double>* const& matrix) {
  Cholmod* solver = solverOf(matrix);
  return !solver || !solver->L || positiveFactor(solver->L);
}

static Cholmod* sized(Matrice_Creuse<double>* const& matrix, KN<double>* const& x, const char* who) {
  Cholmod* solver = factorOf(matrix, who);
  if (x->N() != solver->n) ExecError(std::string(who) + ": the vector's size is not the matrix's");
  return solver;
}

static long factorForward(Matrice_Creuse<double>* const& matrix, KN<double>* const& x) {
  Cholmod* solver = sized(matrix, x, "factorForward");
  apply(solver, {CHOLMOD_P, CHOLMOD_LD}, &(*x)[0], 1);
  return 0;
}

static long factorBackward(Matrice_Creuse<double>* const& matrix, KN<double>* const& x) {
  Cholmod* solver = sized(matrix, x, "factorBackward");
  apply(solver, {CHOLMOD_Lt, CHOLMOD_Pt}, &(*x)[0], 1);
  return 0;
}

// A sparse matrix by columns: the entries of column c are row[k], value[k], start[c] ≤ k < start[c + 1].
struct Columns {
  std::vector<int> start, row;
  std::vector<double> value;
};

static Columns columnsOf(HashMatrix<int, double>& A) {
  Columns C;
  C.start.assign(A.m + 1, 0);
  for (size_t k = 0; k < A.nnz; k++) C.start[A.j[k] + 1]++;
  for (int c = 0; c < A.m; c++) C.start[c + 1] += C.start[c];
  C.row.resize(A.nnz);
  C.value.resize(A.nnz);
  std::vector<int> next(C.start.begin(), C.start.end() - 1);
  for (size_t k = 0; k < A.nnz; k++) {
    int at = next[A.j[k]]++;
    C.row[at] = A.i[k];
    C.value[at] = A.aij[k];
  }
  return C;
}

extern "C" {
void dtrsm_(const char*, const char*, const char*, const char*, const int*, const int*, const double*, const double*,
            const int*, double*, const int*);
void dgemm_(const char*, const char*, const int*, const int*, const int*, const double*, const double*, const int*,
            const double*, const int*, const double*, double*, const int*);
}

// L⁻¹ of a block of columns with few nonzeros, on CHOLMOD's supernodal LLᵀ: only the supernodes
// on the elimination-tree paths from the block's nonzero rows up to the root are touched (the
// others' part of the solution is exactly zero), each as CHOLMOD's own solve does it (the
// triangular solve of its diagonal block, then the product with the rows below, subtracted
// from the ancestors' rows). Y's columns are nonzero on those supernodes' columns only.
struct Supernodes {
  const cholmod_factor* L;
  std::vector<int> ofColumn, parent;
  explicit Supernodes(const cholmod_factor* factor) : L(factor), ofColumn(factor->n), parent(factor->nsuper, -1) {
    const int *super = static_cast<int*>(L->super), *pi = static_cast<int*>(L->pi), *rows = static_cast<int*>(L->s);
    for (size_t s = 0; s < L->nsuper; s++)
      for (int k = super[s]; k < super[s + 1]; k++) ofColumn[k] = static_cast<int>(s);
    for (size_t s = 0; s < L->nsuper; s++) {
      const int columns = super[s + 1] - super[s];
      if (pi[s + 1] - pi[s] > columns) parent[s] = ofColumn[rows[pi[s] + columns]];
    }
  }
  // X (n × size, column-major, zero outside the rows of `path`) ← L⁻¹ X; path: the supernodes
  // from `marked`, ascending (children before parents).
  void solve(double* X, int size, const std::vector<int>& path) const {
    const int *super = static_cast<int*>(L->super), *pi = static_cast<int*>(L->pi), *rows = static_cast<int*>(L->s);
    const int *px = static_cast<int*>(L->px), n = static_cast<int>(L->n);
    const double *Lx = static_cast<double*>(L->x), one = 1, zero = 0;
    std::vector<double> below;
    for (int s : path) {
      const int first = super[s], columns = super[s + 1] - first, height = pi[s + 1] - pi[s], under = height - columns;
      const double* block = Lx + px[s];
      dtrsm_("L", "L", "N", "N", &columns, &size, &one, block, &height, X + first, &n);
      if (under == 0) continue;
      below.assign(static_cast<size_t>(under)*size, 0.);
      dgemm_("N", "N", &under, &size, &columns, &one, block + columns, &height, X + first, &n, &zero, below.data(), &under);
      for (int j = 0; j < size; j++)
        for (int i = 0; i < under; i++) X[static_cast<size_t>(j)*n + rows[pi[s] + columns + i]] -= below[static_cast<size_t>(j)*under + i];
    }
  }
};

static void endColumn(Columns& Y) {
  if (Y.row.size() > static_cast<size_t>(INT_MAX))  // the columns' starts are int
    ExecError("factorColumns: L⁻¹PCᵀ has more than 2^31 - 1 nonzeros");
  Y.start.push_back(static_cast<int>(Y.row.size()));
}

// Y = L⁻¹ P Cᵀ in blocks of `block` columns, each column's exact zeros left out. Supernodal:
// the solve of the blocks' paths above, and only their columns' rows read; simplicial (small
// matrices): CHOLMOD's dense solve, every row read.
static Columns forwardColumns(Cholmod* solver, const Columns& C, int m, int block) {
  const int n = solver->n;
  const cholmod_factor* L = solver->L;
  const int* perm = static_cast<int*>(L->Perm);
  std::vector<int> inverse(n);  // P b: (P b)[k] = b[perm[k]]
  for (int k = 0; k < n; k++) inverse[perm ? perm[k] : k] = k;
  const std::unique_ptr<const Supernodes> tree(L->is_super ? new Supernodes(L) : 0);
  std::vector<char> marked(L->is_super ? L->nsuper : 0, 0);
  Columns Y;
  Y.start.push_back(0);
  std::vector<double> X(static_cast<size_t>(n)*block, 0.);  // zero again after each block
  for (int first = 0; first < m; first += block) {
    const int size = std::min(block, m - first);
    std::vector<int> path;
    for (int j = 0; j < size; j++)
      for (int k = C.start[first + j]; k < C.start[first + j + 1]; k++) {
        const int row = inverse[C.row[k]];
        X[static_cast<size_t>(j)*n + row] += C.value[k];
        if (tree)
          for (int s = tree->ofColumn[row]; s >= 0 && !marked[s]; s = tree->parent[s]) { marked[s] = 1; path.push_back(s); }
      }
    std::vector<std::pair<int, int>> ranges;  // the rows the solution can be nonzero in: [from, to)
    if (tree) {
      std::sort(path.begin(), path.end());
      tree->solve(X.data(), size, path);
      const int* super = static_cast<int*>(L->super);
      for (int s : path) { ranges.push_back(std::make_pair(super[s], super[s + 1])); marked[s] = 0; }
    } else {
      apply(solver, {CHOLMOD_L}, X.data(), size);
      ranges.push_back(std::make_pair(0, n));
    }
    for (int j = 0; j < size; j++) {
      double* column = X.data() + static_cast<size_t>(j)*n;
      for (const auto& range : ranges)
        for (int r = range.first; r < range.second; r++)
          if (column[r] != 0) { Y.row.push_back(r); Y.value.push_back(column[r]); column[r] = 0; }
      endColumn(Y);
    }
  }
  return Y;
}

// Ŷ = D⁻¹ Y of a simplicial LDLᵀ (D: the first entry of each of its columns)
static Columns scaledColumns(const cholmod_factor* L, const Columns& Y) {
  Columns D = Y;
  const int* p = static_cast<int*>(L->p);
  const double* x = static_cast<double*>(L->x);
  for (size_t k = 0; k < D.row.size(); k++) D.value[k] /= x[p[D.row[k]]];
  return D;
}

// S = Yᵀ Ŷ (m × m) row by row of Y: each row adds the products of its entries' pairs; the rows
// with many entries (the supernodes near the root, on every column's path) are gathered into
// dense columns and added by one dgemm.
static void condensed(const Columns& Y, const Columns& D, int n, int m, KNM<double>& S) {
  const int crowded = 16;  // entries from which a row goes to the dgemm
  std::vector<int> count(n + 1, 0);
  for (int r : Y.row) count[r + 1]++;
  for (int r = 0; r < n; r++) count[r + 1] += count[r];
  std::vector<int> next(count.begin(), count.end() - 1), column(Y.row.size());
  std::vector<double> y(Y.row.size()), yHat(Y.row.size());
  for (int c = 0; c < m; c++)
    for (int k = Y.start[c]; k < Y.start[c + 1]; k++) {
      const int at = next[Y.row[k]]++;
      column[at] = c; y[at] = Y.value[k]; yHat[at] = D.value[k];
    }
  S = 0.;
  std::vector<double> G, GHat;  // the crowded rows, one m-column each
  for (int r = 0; r < n; r++) {
    if (count[r + 1] - count[r] >= crowded) {
      G.resize(G.size() + m, 0.); GHat.resize(GHat.size() + m, 0.);
      double *g = &G[G.size() - m], *gHat = &GHat[GHat.size() - m];
      for (int a = count[r]; a < count[r + 1]; a++) { g[column[a]] = y[a]; gHat[column[a]] = yHat[a]; }
      continue;
    }
    for (int a = count[r]; a < count[r + 1]; a++)
      for (int b = count[r]; b < count[r + 1]; b++) S(column[a], column[b]) += y[a]*yHat[b];
  }
  const int rows = static_cast<int>(G.size()/std::max(m, 1));
  const double one = 1;
  if (rows > 0) dgemm_("N", "T", &m, &m, &rows, &one, G.data(), &m, GHat.data(), &m, &one, &S(0, 0), &m);
}

// Y and Ŷ of the bodies' factors, by the number factorColumns gave (kept for the process).
struct Condensed {
  int n, m;
  Columns Y;
  std::vector<double> hat;  // Ŷ's values in Y's pattern; empty where Ŷ = Y (LLᵀ)
};
static std::vector<std::unique_ptr<const Condensed>> condensedKept;

static long factorColumns(Matrice_Creuse<double>* const& matrix, Matrice_Creuse<double>* const& transposedC,
                          KNM<double>* const& S, long const& columnBlock) {
  Cholmod* solver = factorOf(matrix, "factorColumns");
  HashMatrix<int, double>* Ct = transposedC->pHM();
  if (!Ct || Ct->n != solver->n) ExecError("factorColumns: Cᵀ needs as many rows as the matrix");
  const int n = solver->n, m = Ct->m;
  if (S->N() != m || S->M() != m || !S->IsVector1())
    ExecError("factorColumns: S must be a whole m × m array for the m columns of Cᵀ");
  if (columnBlock < 1) ExecError("factorColumns: columnBlock must be at least 1");
  if (std::min<long>(columnBlock, m)*n > INT_MAX)  // CHOLMOD's dense blocks are indexed in int here
    ExecError("factorColumns: a block of more than 2^31 - 1 numbers; give a smaller columnBlock");
  std::unique_ptr<Condensed> kept(new Condensed{n, m, forwardColumns(solver, columnsOf(*Ct), m,
                                                static_cast<int>(std::min<long>(columnBlock, std::max(m, 1)))), {}});
  if (solver->L->is_ll) condensed(kept->Y, kept->Y, n, m, *S);
  else {
    const Columns scaled = scaledColumns(solver->L, kept->Y);
    condensed(kept->Y, scaled, n, m, *S);
    kept->hat = scaled.value;
  }
  condensedKept.emplace_back(std::move(kept));
  return static_cast<long>(condensedKept.size()) - 1;
}

static const Condensed& keptColumns(long Y, const char* who) {
  if (Y < 0 || Y >= static_cast<long>(condensedKept.size()) || !condensedKept[Y])
    ExecError(std::string(who) + ": Y is not a number factorColumns gave, or it was forgotten");
  return *condensedKept[Y];
}

static const Condensed& condensedOf(long Y, long rows, long columns, const char* who) {
  const Condensed& C = keptColumns(Y, who);
  if (C.n != rows || C.m != columns) ExecError(std::string(who) + ": the vectors' sizes are not those of Y (n × m)");
  return C;
}

static long columnNonzeros(long const& Y) {
  return static_cast<long>(keptColumns(Y, "columnNonzeros").Y.row.size());
}

static long forgetColumns(long const& Y) {
  keptColumns(Y, "forgetColumns");
  condensedKept[Y].reset();
  return 0;
}

// y += Yᵀ z: each column's entries make a dot product, summed in four partial sums (one sum
// would wait on its last addition at every entry).
static long addTransposedProduct(long const& Y, KN<double>* const& z, KN<double>* const& y) {
  const Condensed& C = condensedOf(Y, z->N(), y->N(), "addTransposedProduct");
  const double *zz = &(*z)[0], *a = C.Y.value.data();
  const int* row = C.Y.row.data();
  double* yy = &(*y)[0];
  for (int c = 0; c < C.m; c++) {
    int k = C.Y.start[c];
    const int end = C.Y.start[c + 1];
    double s0 = 0, s1 = 0, s2 = 0, s3 = 0;
    for (; k + 4 <= end; k += 4) {
      s0 += a[k]*zz[row[k]]; s1 += a[k + 1]*zz[row[k + 1]];
      s2 += a[k + 2]*zz[row[k + 2]]; s3 += a[k + 3]*zz[row[k + 3]];
    }
    for (; k < end; k++) s0 += a[k]*zz[row[k]];
    yy[c] += (s0 + s1) + (s2 + s3);
  }
  return 0;
}

// u −= Ŷ λ, column by column, the columns of λ_j = 0 passed over (the nodes off the active set)
static long subtractProduct(long const& Y, KN<double>* const& lambda, KN<double>* const& u) {
  const Condensed& C = condensedOf(Y, u->N(), lambda->N(), "subtractProduct");
  const double* l = &(*lambda)[0];
  const double* a = C.hat.empty() ? C.Y.value.data() : C.hat.data();
  const int* row = C.Y.row.data();
  double* uu = &(*u)[0];
  for (int c = 0; c < C.m; c++)
    if (l[c] != 0)
      for (int k = C.Y.start[c]; k < C.Y.start[c + 1]; k++) uu[row[k]] -= a[k]*l[c];
  return 0;
}

static void init() {
  Global.Add("factorComplete", "(", new OneOperator1_<bool, Matrice_Creuse<double>*>(factorComplete));
  Global.Add("factorForward", "(", new OneOperator2_<long, Matrice_Creuse<double>*, KN<double>*>(factorForward));
  Global.Add("factorBackward", "(", new OneOperator2_<long, Matrice_Creuse<double>*, KN<double>*>(factorBackward));
  Global.Add("addTransposedProduct", "(", new OneOperator3_<long, long, KN<double>*, KN<double>*>(addTransposedProduct));
  Global.Add("subtractProduct", "(", new OneOperator3_<long, long, KN<double>*, KN<double>*>(subtractProduct));
  Global.Add("columnNonzeros", "(", new OneOperator1_<long, long>(columnNonzeros));
  Global.Add("forgetColumns", "(", new OneOperator1_<long, long>(forgetColumns));
  Global.Add("factorColumns", "(",
             new OneOperator4_<long, Matrice_Creuse<double>*, Matrice_Creuse<double>*, KNM<double>*, long>(factorColumns));
}

LOADFUNC(init)
