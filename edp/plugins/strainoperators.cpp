// A body's strain operators in compact form (edp/lib/body.idp): for each strain point p (with P1
// displacements, a triangle's centroid; any number of points per element and of nodes per point),
// the nodes whose shape functions φ_a act there and their gradients (∂xφ_a, ∂yφ_a)(p). A step's
// strains and its force of a stress each read these once, where FreeFEM's sparse matrices for
// ε11, ε22 and γ12 (and their transposes) read every gradient again with two indices, a product
// each (measured: docs/model-choices.md, "The constitutive law in the scripts"). Kinematics only:
// the material's law stays in edp/lib/material.idp. The arrays are the script's (no state here):
//   strainOperators(Dx, Dy, rowStart, node, gradient)
//       from Dx = ∂x of the x-component and Dy = ∂y of the y-component (points × [Pk, Pk], the
//       dofs of a node interleaved x, y, as FreeFEM's interpolate gives them), fills rowStart
//       (points + 1: point p's entries are rowStart[p] ... rowStart[p+1] − 1), node (each entry's
//       x-dof) and gradient (2 per entry: ∂xφ, ∂yφ); returns the number of points
//   strainsOf(rowStart, node, gradient, u, e11, e22, g12, density)
//       ε11 = Σ ∂xφ_a u_ax, ε22 = Σ ∂yφ_a u_ay, γ12 = 2ε12 = Σ (∂yφ_a u_ax + ∂xφ_a u_ay) per point, and
//       density = ε:ε = ε11² + ε22² + ½γ12², the strain's square (the energy norm's integrand)
//   stressForce(rowStart, node, gradient, weight, s11, s22, s12, force)
//       force = Σ_p weight_p σ_p : ε_p(v) for every test function v, σ given per point (s12 = σ12):
//       the integral (σ, ε(v)) by the quadrature whose points and weights these are
#include <algorithm>
#include <vector>
#include "ff++.hpp"
#include "AFunction_ext.hpp"

typedef HashMatrix<int, double> Entries;

// A sparse matrix's rows, each row's (column, value) entries together.
struct Rows {
  std::vector<long> start;
  std::vector<int> column;
  std::vector<double> value;
  Rows(const Entries& A, const char* name) : start(A.n + 1, 0), column(A.nnz), value(A.nnz) {
    if (A.half || A.fortran) ExecError(std::string("strainOperators: ") + name + " must be a general sparse matrix");
    for (size_t k = 0; k < A.nnz; k++) start[A.i[k] + 1]++;
    for (long r = 0; r < A.n; r++) start[r + 1] += start[r];
    std::vector<long> next(start.begin(), start.end() - 1);
    for (size_t k = 0; k < A.nnz; k++) {
      column[next[A.i[k]]] = A.j[k];
      value[next[A.i[k]]++] = A.aij[k];
    }
  }
};

static long strainOperators(Matrice_Creuse<double>* const& Dx, Matrice_Creuse<double>* const& Dy, KN<long>* const& rowStart,
                            KN<long>* const& node, KN<double>* const& gradient) {
  const Entries *x = Dx->pHM(), *y = Dy->pHM();
  if (!x || !y) ExecError("strainOperators: Dx and Dy must be sparse matrices");
  if (x->n != y->n || x->m != y->m || x->m % 2) ExecError("strainOperators: Dx and Dy are not both points × [Pk, Pk]");
  const Rows dx(*x, "Dx"), dy(*y, "Dy");
  std::vector<long> start(1, 0), nodes;
  std::vector<double> values;  // (∂xφ, ∂yφ) of each entry
  nodes.reserve(x->nnz + y->nnz);
  values.reserve(2*(x->nnz + y->nnz));
  for (long p = 0; p < x->n; p++) {
    const long first = static_cast<long>(nodes.size());
    for (long k = dx.start[p]; k < dx.start[p + 1]; k++) {  // each node once, its x-dof, in Dx's order
      if (dx.column[k] % 2 != 0) ExecError("strainOperators: Dx has an entry on a y-component dof");
      long q = first;
      while (q < static_cast<long>(nodes.size()) && nodes[q] != dx.column[k]) q++;
      if (q == static_cast<long>(nodes.size())) { nodes.push_back(dx.column[k]); values.push_back(0); values.push_back(0); }
      values[2*q] += dx.value[k];
    }
    for (long k = dy.start[p]; k < dy.start[p + 1]; k++) {  // then the nodes Dx did not name
      if (dy.column[k] % 2 != 1) ExecError("strainOperators: Dy has an entry on an x-component dof");
      long q = first;
      while (q < static_cast<long>(nodes.size()) && nodes[q] != dy.column[k] - 1) q++;
      if (q == static_cast<long>(nodes.size())) { nodes.push_back(dy.column[k] - 1); values.push_back(0); values.push_back(0); }
      values[2*q + 1] += dy.value[k];
    }
    start.push_back(static_cast<long>(nodes.size()));
  }
  rowStart->resize(start.size());
  node->resize(nodes.size());
  gradient->resize(values.size());
  std::copy(start.begin(), start.end(), &(*rowStart)[0]);
  if (!nodes.empty()) {
    std::copy(nodes.begin(), nodes.end(), &(*node)[0]);
    std::copy(values.begin(), values.end(), &(*gradient)[0]);
  }
  return x->n;
}

// The operator's arrays checked against each other and the sizes of a call; each point's entries
// and each entry's node are checked as the loops read them (a bad one stops the run, never reads
// outside the arrays, u or the force).
struct Operator {
  const long* start;
  const long* node;
  const double* gradient;
  long points, entries;
  unsigned long lastNode;  // a node's x-dof lies in [0, dofs − 2]
  Operator(const KN<long>& s, const KN<long>& n, const KN<double>& g, long dofs, const char* who) {
    points = s.N() - 1;
    if (points < 0 || s[0] != 0 || s[points] != n.N() || g.N() != 2*n.N() || dofs < 2)
      ExecError(std::string(who) + ": rowStart, node and gradient are not an operator strainOperators made");
    entries = n.N();
    start = &s[0]; node = n.N() ? &n[0] : 0; gradient = g.N() ? &g[0] : 0;
    lastNode = static_cast<unsigned long>(dofs - 2);
  }
  // Point p's entries, checked as the loops reach them: an end before its start would skip them.
  long end(long p, const char* who) const {
    if (start[p + 1] < start[p] || start[p + 1] > entries) ExecError(std::string(who) + ": rowStart does not increase from 0 to the number of entries");
    return start[p + 1];
  }
  long at(long q, const char* who) const {
    if (static_cast<unsigned long>(node[q]) > lastNode) ExecError(std::string(who) + ": a node lies outside the displacement's dofs");
    return node[q];
  }
};

static void requireSize(const KN<double>* v, long n, const char* who, const char* what) {
  if (v->N() != n) ExecError(std::string(who) + ": " + what + " has not one value per strain point");
}

static long strainsOf(KN<long>* const& rowStart, KN<long>* const& node, KN<double>* const& gradient, KN<double>* const& u,
                      KN<double>* const& e11, KN<double>* const& e22, KN<double>* const& g12, KN<double>* const& density) {
  const Operator op(*rowStart, *node, *gradient, u->N(), "strainsOf");
  for (KN<double>* v : {e11, e22, g12, density}) requireSize(v, op.points, "strainsOf", "a strain or density");
  const double* uu = &(*u)[0];
  for (long p = 0; p < op.points; p++) {
    double a = 0, b = 0, g = 0;
    for (long q = op.start[p], end = op.end(p, "strainsOf"); q < end; q++) {
      const long d = op.at(q, "strainsOf");
      const double gx = op.gradient[2*q], gy = op.gradient[2*q + 1], ux = uu[d], uy = uu[d + 1];
      a += gx*ux;
      b += gy*uy;
      g += gy*ux + gx*uy;
    }
    (*e11)[p] = a; (*e22)[p] = b; (*g12)[p] = g;
    (*density)[p] = a*a + b*b + 0.5*(g*g);
  }
  return op.points;
}

static long stressForce(KN<long>* const& rowStart, KN<long>* const& node, KN<double>* const& gradient,
                        KN<double>* const& weight, KN<double>* const& s11, KN<double>* const& s22, KN<double>* const& s12,
                        KN<double>* const& force) {
  const Operator op(*rowStart, *node, *gradient, force->N(), "stressForce");
  for (KN<double>* v : {weight, s11, s22, s12}) requireSize(v, op.points, "stressForce", "a weight or stress");
  double* f = &(*force)[0];
  std::fill(f, f + force->N(), 0.);
  for (long p = 0; p < op.points; p++) {
    const double w = (*weight)[p], a = w*(*s11)[p], b = w*(*s22)[p], c = w*(*s12)[p];
    for (long q = op.start[p], end = op.end(p, "stressForce"); q < end; q++) {
      const long d = op.at(q, "stressForce");
      const double gx = op.gradient[2*q], gy = op.gradient[2*q + 1];
      f[d] += gx*a + gy*c;
      f[d + 1] += gy*b + gx*c;
    }
  }
  return op.points;
}

static void init() {
  Global.Add("strainOperators", "(", new OneOperator5_<long, Matrice_Creuse<double>*, Matrice_Creuse<double>*, KN<long>*,
                                                       KN<long>*, KN<double>*>(strainOperators));
  Global.Add("strainsOf", "(", new OneOperator8_<long, KN<long>*, KN<long>*, KN<double>*, KN<double>*, KN<double>*,
                                                 KN<double>*, KN<double>*, KN<double>*>(strainsOf));
  Global.Add("stressForce", "(", new OneOperator8_<long, KN<long>*, KN<long>*, KN<double>*, KN<double>*, KN<double>*,
                                                   KN<double>*, KN<double>*, KN<double>*>(stressForce));
}

LOADFUNC(init)
