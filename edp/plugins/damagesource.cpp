// The right-hand side of a body's damage step (docs/model.md §3, §6; edp/lib/damage.idp) in one
// call, where the script took about fifteen vector operations and two sparse products:
//   int ops = damageOperators(Md, Q)                 the mass matrix and the P0 → P1 loads, kept
//                                                    here row by row
//   int below = damageSource(ops, data, inertia, zeta, density, b)
//   data = [lambdaD, lambdaU, lambdaW, zetaMin, L]
// b = M(inertia + λ_D (1 − ζc)/ζc + λ_w) − ½ λ_u Q R(ε:ε),  ζc = max(ζ, ζ_min), R(s) = min(s, L);
// returns the number of nodes where ζ < ζ_min. Every value with the operations, in the order, of
// the script it replaces (the results are its own to the bit; tests/test_damage_source.py):
// (1 − ζc)/ζc as 1/ζc − 1, added as λ_D/ζc, then λ_w − λ_D; max(ζ, ζ_min) and min(s, L) as
// arrays.idp's maxWith, minWith write them ((|v − c| + v) + c)/2 and ((−|v − c| + v) + c)/2; the
// clamp and the truncation only where they act (ζ's least value below ζ_min, ε:ε's largest above
// L, as FreeFEM's min and max find them, NaN and all); the count of nodes below as arrays.idp's
// positivePart01 summed; a product as FreeFEM's, each row summed from 0 in its matrix's order.
#include <cmath>
#include <limits>
#include <memory>
#include <vector>
#include "ff++.hpp"
#include "AFunction_ext.hpp"

typedef HashMatrix<int, double> Entries;

// A sparse matrix's rows, each row's entries in the order they are stored.
struct Rows {
  long n, m;
  std::vector<long> start;
  std::vector<int> column;
  std::vector<double> value;
  Rows(const Entries& A, const char* name) : n(A.n), m(A.m), start(A.n + 1, 0), column(A.nnz), value(A.nnz) {
    if (A.half || A.fortran) ExecError(std::string("damageOperators: ") + name + " must be a general sparse matrix");
    for (size_t k = 0; k < A.nnz; k++) start[A.i[k] + 1]++;
    for (long r = 0; r < n; r++) start[r + 1] += start[r];
    std::vector<long> next(start.begin(), start.end() - 1);
    for (size_t k = 0; k < A.nnz; k++) {
      column[next[A.i[k]]] = A.j[k];
      value[next[A.i[k]]++] = A.aij[k];
    }
  }
  // y = A x
  void times(const double* x, double* y) const {
    for (long r = 0; r < n; r++) {
      double s = 0;
      for (long k = start[r]; k < start[r + 1]; k++) s += value[k]*x[column[k]];
      y[r] = s;
    }
  }
};

struct DamageOperators {
  Rows mass, load;
};
static std::vector<std::unique_ptr<const DamageOperators>> kept;

static long damageOperators(Matrice_Creuse<double>* const& Md, Matrice_Creuse<double>* const& Q) {
  const Entries *M = Md->pHM(), *L = Q->pHM();
  if (!M || !L) ExecError("damageOperators: Md and Q must be sparse matrices");
  if (M->n != M->m || L->n != M->n) ExecError("damageOperators: Md (P1 × P1) and Q (P1 × P0) are not of one mesh");
  kept.emplace_back(new DamageOperators{Rows(*M, "Md"), Rows(*L, "Q")});
  return static_cast<long>(kept.size()) - 1;
}

// FreeFEM's min and max of an array (KN_::min, max): from the largest (lowest) double, each value
// kept unless the running one compares below (above) it, so a NaN is taken and then passed over
static double leastOf(const KN<double>& v) {
  double m = std::numeric_limits<double>::max();
  for (long j = 0; j < v.N(); j++) m = m < v[j] ? m : v[j];
  return m;
}
static double largestOf(const KN<double>& v) {
  double m = std::numeric_limits<double>::lowest();
  for (long j = 0; j < v.N(); j++) m = m > v[j] ? m : v[j];
  return m;
}

static long damageSource(long const& o, KN<double>* const& data, KN<double>* const& inertia, KN<double>* const& zeta,
                         KN<double>* const& density, KN<double>* const& b) {
  if (o < 0 || o >= static_cast<long>(kept.size())) ExecError("damageSource: not a number damageOperators gave");
  const DamageOperators& ops = *kept[o];
  if (data->N() != 5) ExecError("damageSource: data = [lambdaD, lambdaU, lambdaW, zetaMin, L]");
  const long n = ops.mass.n;
  if (inertia->N() != n || zeta->N() != n || b->N() != n || density->N() != ops.load.m)
    ExecError("damageSource: the arrays have not the sizes of the body's damage operators");
  const double lambdaD = (*data)[0], lambdaU = (*data)[1], lambdaW = (*data)[2], zetaMin = (*data)[3], L = (*data)[4];
  std::vector<double> nodal(n);
  long below = 0;
  if (lambdaD != 0) {
    const bool clamped = leastOf(*zeta) < zetaMin;
    double count = 0;
    for (long j = 0; j < n; j++) {
      const double z = (*zeta)[j];
      double inverse;
      if (clamped) {
        const double gap = -z + zetaMin, size = std::fabs(gap);
        count += (gap + size)/(2*size + 1e-300);
        inverse = 1/(((std::fabs(z - zetaMin) + z) + zetaMin)*0.5);
      } else inverse = 1/z;
      nodal[j] = (*inertia)[j] + lambdaD*inverse;
    }
    below = std::lrint(count);
  } else
    for (long j = 0; j < n; j++) nodal[j] = (*inertia)[j];
  const double shift = lambdaW - lambdaD;
  for (long j = 0; j < n; j++) nodal[j] += shift;
  ops.mass.times(nodal.data(), &(*b)[0]);
  if (lambdaU != 0) {
    std::vector<double> cells(ops.load.m), loads(n);
    const double* source = &(*density)[0];
    if (!(largestOf(*density) <= L)) {
      for (long t = 0; t < ops.load.m; t++) cells[t] = ((-std::fabs(source[t] - L) + source[t]) + L)*0.5;
      source = cells.data();
    }
    ops.load.times(source, loads.data());
    const double half = 0.5*lambdaU;
    for (long j = 0; j < n; j++) (*b)[j] -= half*loads[j];
  }
  return below;
}

static void init() {
  Global.Add("damageOperators", "(", new OneOperator2_<long, Matrice_Creuse<double>*, Matrice_Creuse<double>*>(damageOperators));
  Global.Add("damageSource", "(", new OneOperator6_<long, long, KN<double>*, KN<double>*, KN<double>*, KN<double>*,
                                                    KN<double>*>(damageSource));
}

LOADFUNC(init)
