// A body's strain operators (edp/lib/body.idp), kept per triangle by this plugin: the
// derivatives of the P1 hat functions that FreeFEM's interpolate gives, and the triangle areas.
// A step's products with them read 3 derivatives and 3 indices a row, where the sparse matrices
// they replace (Dx, Dy, G12 = ∂y u_x + ∂x u_y, Dᵀdiag(|T|) of each, the P1 → P0 mean) held each
// nonzero again with two indices, and each product was a pass of its own:
//   int ops = strainOperators(Dx, Dy, Avg, area)   from Dx = ∂x of the x-component and Dy = ∂y of
//                                                  the y-component (P0 × [P1, P1], dofs interleaved
//                                                  x, y per vertex), Avg (P0 × P1) and |T|
//   strainsOf(ops, u, e11, e22, g12, density)      ε11 = Dx u, ε22 = Dy u, γ12 = G12 u per triangle,
//                                                  and ε:ε = (ε11² + ε22²) + ½γ12²
//   stressForce(ops, s11, s22, s12, force)         force = (Dxᵀ|T| s11 + Dyᵀ|T| s22) + G12ᵀ|T| s12:
//                                                  (σ, ε(v)) for each test function v
//   triangleMeans(ops, z, zBar)                    zBar = Avg z
// Every result is the one FreeFEM's matrices gave, to the bit (tests/test_strain_operators.py): a
// matrix-vector product sums each row from 0 in the order of its stored entries, which these
// kernels keep: a row of Dx, Dy or Avg in its matrix's order; G12's row of a triangle holds its
// ∂y entries, then its ∂x ones (FreeFEM's A + B keeps A's, then B's; G12's values are Dy's at the
// x-component, Dx's at the y-component); a row of Dᵀdiag(|T|) holds its triangles in increasing
// order, each entry D's times |T| (FreeFEM's transpose and product), which the scatter below adds
// in that order. Exact zeros that interpolate leaves out stay out.
#include <memory>
#include <vector>
#include "ff++.hpp"
#include "AFunction_ext.hpp"

typedef HashMatrix<int, double> Entries;

// Up to three entries a row (a P1 triangle's vertices), in their matrix's order.
struct Rows {
  std::vector<unsigned char> count;
  std::vector<int> column;
  std::vector<double> value;
  explicit Rows(const Entries& A, const char* name) : count(A.n, 0), column(3*static_cast<size_t>(A.n)), value(3*static_cast<size_t>(A.n)) {
    if (A.half || A.fortran) ExecError(std::string("strainOperators: ") + name + " must be a general sparse matrix");
    for (size_t k = 0; k < A.nnz; k++) {
      const int t = A.i[k];
      if (count[t] == 3) ExecError(std::string("strainOperators: ") + name + " has a row of more than 3 entries (not a P1 operator)");
      column[3*static_cast<size_t>(t) + count[t]] = A.j[k];
      value[3*static_cast<size_t>(t) + count[t]] = A.aij[k];
      count[t]++;
    }
  }
};

struct StrainOperators {
  long triangles, dofs, nodes;
  Rows dx, dy, mean;
  std::vector<double> area;
};
static std::vector<std::unique_ptr<const StrainOperators>> kept;

static const StrainOperators& operatorsOf(long ops, const char* who) {
  if (ops < 0 || ops >= static_cast<long>(kept.size())) ExecError(std::string(who) + ": not a number strainOperators gave");
  return *kept[ops];
}

static void requireSize(const KN<double>* v, long n, const char* who, const char* what) {
  if (v->N() != n) ExecError(std::string(who) + ": " + what + " has not the size of the body's operators");
}

static long strainOperators(Matrice_Creuse<double>* const& Dx, Matrice_Creuse<double>* const& Dy,
                            Matrice_Creuse<double>* const& Avg, KN<double>* const& area) {
  const Entries *x = Dx->pHM(), *y = Dy->pHM(), *m = Avg->pHM();
  if (!x || !y || !m) ExecError("strainOperators: Dx, Dy and Avg must be sparse matrices");
  if (x->n != y->n || x->m != y->m || x->m % 2 || m->n != x->n || 2*m->m != x->m || area->N() != x->n)
    ExecError("strainOperators: Dx, Dy (P0 × [P1, P1]), Avg (P0 × P1) and the areas are not of one mesh");
  std::unique_ptr<StrainOperators> ops(new StrainOperators{x->n, x->m, m->m, Rows(*x, "Dx"), Rows(*y, "Dy"), Rows(*m, "Avg"),
                                                           std::vector<double>(&(*area)[0], &(*area)[0] + area->N())});
  for (long t = 0; t < ops->triangles; t++)
    for (int q = 0; q < 3; q++) {
      if (q < ops->dx.count[t] && ops->dx.column[3*t + q] % 2 != 0) ExecError("strainOperators: Dx has an entry on a y-component dof");
      if (q < ops->dy.count[t] && ops->dy.column[3*t + q] % 2 != 1) ExecError("strainOperators: Dy has an entry on an x-component dof");
    }
  kept.emplace_back(std::move(ops));
  return static_cast<long>(kept.size()) - 1;
}

static long strainsOf(long const& o, KN<double>* const& u, KN<double>* const& e11, KN<double>* const& e22,
                      KN<double>* const& g12, KN<double>* const& density) {
  const StrainOperators& ops = operatorsOf(o, "strainsOf");
  requireSize(u, ops.dofs, "strainsOf", "u");
  for (KN<double>* v : {e11, e22, g12, density}) requireSize(v, ops.triangles, "strainsOf", "a per-triangle array");
  const double* uu = &(*u)[0];
  for (long t = 0; t < ops.triangles; t++) {
    const size_t at = 3*static_cast<size_t>(t);
    const int nx = ops.dx.count[t], ny = ops.dy.count[t];
    const int* cx = &ops.dx.column[at];
    const int* cy = &ops.dy.column[at];
    const double* vx = &ops.dx.value[at];
    const double* vy = &ops.dy.value[at];
    double a = 0, b = 0, g = 0;
    for (int q = 0; q < nx; q++) a += vx[q]*uu[cx[q]];
    for (int q = 0; q < ny; q++) b += vy[q]*uu[cy[q]];
    for (int q = 0; q < ny; q++) g += vy[q]*uu[cy[q] - 1];  // ∂y of the x-component
    for (int q = 0; q < nx; q++) g += vx[q]*uu[cx[q] + 1];  // then ∂x of the y-component
    (*e11)[t] = a; (*e22)[t] = b; (*g12)[t] = g;
    (*density)[t] = (a*a + b*b) + 0.5*(g*g);  // the grouping of the script it replaced
  }
  return 0;
}

static long stressForce(long const& o, KN<double>* const& s11, KN<double>* const& s22, KN<double>* const& s12,
                        KN<double>* const& force) {
  const StrainOperators& ops = operatorsOf(o, "stressForce");
  for (KN<double>* v : {s11, s22, s12}) requireSize(v, ops.triangles, "stressForce", "a stress");
  requireSize(force, ops.dofs, "stressForce", "the force");
  static std::vector<double> fx, fy, fg;  // Dxᵀ|T|s11, Dyᵀ|T|s22, G12ᵀ|T|s12, each summed apart
  fx.assign(ops.dofs, 0.); fy.assign(ops.dofs, 0.); fg.assign(ops.dofs, 0.);
  for (long t = 0; t < ops.triangles; t++) {
    const size_t at = 3*static_cast<size_t>(t);
    const double w = ops.area[t], a = (*s11)[t], b = (*s22)[t], c = (*s12)[t];
    for (int q = 0; q < ops.dx.count[t]; q++) {
      const double entry = ops.dx.value[at + q]*w;
      fx[ops.dx.column[at + q]] += entry*a;
      fg[ops.dx.column[at + q] + 1] += entry*c;
    }
    for (int q = 0; q < ops.dy.count[t]; q++) {
      const double entry = ops.dy.value[at + q]*w;
      fy[ops.dy.column[at + q]] += entry*b;
      fg[ops.dy.column[at + q] - 1] += entry*c;
    }
  }
  for (long d = 0; d < ops.dofs; d++) (*force)[d] = (fx[d] + fy[d]) + fg[d];
  return 0;
}

static long triangleMeans(long const& o, KN<double>* const& z, KN<double>* const& zBar) {
  const StrainOperators& ops = operatorsOf(o, "triangleMeans");
  requireSize(z, ops.nodes, "triangleMeans", "the nodal field");
  requireSize(zBar, ops.triangles, "triangleMeans", "the means");
  const double* zz = &(*z)[0];
  for (long t = 0; t < ops.triangles; t++) {
    const size_t at = 3*static_cast<size_t>(t);
    double s = 0;
    for (int q = 0; q < ops.mean.count[t]; q++) s += ops.mean.value[at + q]*zz[ops.mean.column[at + q]];
    (*zBar)[t] = s;
  }
  return 0;
}

static void init() {
  Global.Add("strainOperators", "(", new OneOperator4_<long, Matrice_Creuse<double>*, Matrice_Creuse<double>*,
                                                       Matrice_Creuse<double>*, KN<double>*>(strainOperators));
  Global.Add("strainsOf", "(", new OneOperator6_<long, long, KN<double>*, KN<double>*, KN<double>*, KN<double>*,
                                                 KN<double>*>(strainsOf));
  Global.Add("stressForce", "(", new OneOperator5_<long, long, KN<double>*, KN<double>*, KN<double>*, KN<double>*>(stressForce));
  Global.Add("triangleMeans", "(", new OneOperator3_<long, long, KN<double>*, KN<double>*>(triangleMeans));
}

LOADFUNC(init)
