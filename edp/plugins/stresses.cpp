// The per-triangle stresses of a body at a step (docs/model.md §8; edp/lib/body.idp, bodyFigures) in
// one pass over the triangles, where the script took about 30 vector operations, each a pass of
// its own (a third of a step's work beyond the back-substitutions at h1 = 6/96):
//   real vmMax = stresses(material, zetaBar, e11, e22, g12, e11Old, e22Old, g12Old,
//                         e11Old2, e22Old2, g12Old2, s11, s22, s12, s33, vmSquared,
//                         elastic11, elastic22, elastic12)
//   material = [aG, bG, mu, eta, k, planeStrain, bdf2Rate]
//   strainDensity(e11, e22, g12, density)   ε:ε = ε11² + ε22² + ½γ12² per triangle: Σ_T |T| ε_T:ε_T
//                                           is the square of a body's part of ‖u‖_V, and ε:ε of
//                                           uⁿ⁻¹ (or u*) drives the damage source
// From the strains of uⁿ (e11 = ε11, e22 = ε22, g12 = γ12 = 2ε12, per triangle), those of uⁿ⁻¹
// and uⁿ⁻², and ζ̄ⁿ (ζ averaged on the triangle):
//   k·ε(u̇ⁿ) = d  = ε(uⁿ) − ε(uⁿ⁻¹)                      (Euler steps; bdf2's first)
//                 = 1.5 ε(uⁿ) − 2 ε(uⁿ⁻¹) + 0.5 ε(uⁿ⁻²)  (bdf2Rate = 1)
//   elastic = ζ̄ G ε(uⁿ):  elastic11 = aG ζ̄ tr ε + bG ζ̄ ε11,  elastic12 = ½ bG ζ̄ γ12
//   σ = A ε(u̇ⁿ) + ζ̄ G ε(uⁿ):  s11 = (μ/k) tr d + (η/k) d11 + elastic11,  s12 = elastic12 + (½η/k) dγ12
//   σ33 = 0 in plane stress; in plane strain (ε33 = 0) (μ/k) tr d + aG ζ̄ tr ε (aG = λ there)
//   vmSquared = σ11² + σ22² + σ33² − σ11σ22 − σ22σ33 − σ33σ11 + 3σ12²;  returns √max vmSquared.
// elastic11, elastic22, elastic12 are the next step's explicit elastic force. Every value is
// computed with the operations, in the order, of the script it replaces, so the results are its
// own to the bit (tests/test_unchanged.py; no fused multiply-add: ff-c++ builds for generic x86-64).
#include <cmath>
#include <limits>
#include "ff++.hpp"
#include "AFunction_ext.hpp"

class Stresses : public E_F0mps {
 public:
  typedef double Result;
  enum { material, zetaBar, e11, e22, g12, e11Old, e22Old, g12Old, e11Old2, e22Old2, g12Old2,
         s11, s22, s12, s33, vmSquared, elastic11, elastic22, elastic12, arguments };
  Expression argument[arguments];
  explicit Stresses(const basicAC_F0& args) {
    args.SetNameParam(0, 0, 0);
    if (args.size() != arguments) CompileError("stresses: 19 arguments (material, zetaBar, 9 strains, 8 results)");
    for (int a = 0; a < arguments; a++) argument[a] = to<KN<double>*>(args[a]);
  }
  static ArrayOfaType typeargs() { return ArrayOfaType(atype<KN<double>*>(), true); }
  static E_F0* f(const basicAC_F0& args) { return new Stresses(args); }
  operator aType() const { return atype<double>(); }
  AnyType operator()(Stack stack) const;
};

AnyType Stresses::operator()(Stack stack) const {
  KN<double>* v[arguments];
  for (int a = 0; a < arguments; a++) v[a] = GetAny<KN<double>*>((*argument[a])(stack));
  const KN<double>& m = *v[material];
  if (m.N() != 7) ExecError("stresses: material = [aG, bG, mu, eta, k, planeStrain, bdf2Rate]");
  const long n = v[zetaBar]->N();
  for (int a = zetaBar; a < arguments; a++)
    if (v[a]->N() != n) ExecError("stresses: every per-triangle array must have one value per triangle");
  const double aG = m[0], bG = m[1], mu = m[2], eta = m[3], k = m[4];
  const bool planeStrain = m[5] != 0, bdf2Rate = m[6] != 0;
  const double muk = mu/k, etak = eta/k, shear = 0.5*bG, shearRate = 0.5*eta/k;
  double* x[arguments];
  for (int a = zetaBar; a < arguments; a++) x[a] = &(*v[a])[0];
  double largest = std::numeric_limits<double>::lowest();
  for (long t = 0; t < n; t++) {
    double d11, d22, dg12;
    if (bdf2Rate) {
      d11 = (1.5*x[e11][t] + (-2.)*x[e11Old][t]) + 0.5*x[e11Old2][t];
      d22 = (1.5*x[e22][t] + (-2.)*x[e22Old][t]) + 0.5*x[e22Old2][t];
      dg12 = (1.5*x[g12][t] + (-2.)*x[g12Old][t]) + 0.5*x[g12Old2][t];
    } else {
      d11 = x[e11][t] - x[e11Old][t];
      d22 = x[e22][t] - x[e22Old][t];
      dg12 = x[g12][t] - x[g12Old][t];
    }
    const double z = x[zetaBar][t], trace = x[e11][t] + x[e22][t];
    const double zeTrace = z*trace, ze11 = z*x[e11][t], ze22 = z*x[e22][t], zg12 = z*x[g12][t];
    const double el11 = aG*zeTrace + bG*ze11, el22 = aG*zeTrace + bG*ze22, el12 = shear*zg12;
    const double rateTrace = d11 + d22;
    const double sxx = (muk*rateTrace + etak*d11) + el11, syy = (muk*rateTrace + etak*d22) + el22;
    const double sxy = el12 + shearRate*dg12;
    double vm = ((sxx*sxx + syy*syy) - sxx*syy) + 3*(sxy*sxy);
    if (planeStrain) {
      const double szz = muk*rateTrace + aG*zeTrace;
      vm = (vm + szz*szz) - szz*(sxx + syy);
      x[s33][t] = szz;
    }
    x[elastic11][t] = el11; x[elastic22][t] = el22; x[elastic12][t] = el12;
    x[s11][t] = sxx; x[s22][t] = syy; x[s12][t] = sxy; x[vmSquared][t] = vm;
    largest = largest > vm ? largest : vm;  // FreeFEM's max of an array, NaN and all (RNM::Max)
  }
  return std::sqrt(largest);
}

// density = ε:ε = ε11² + ε22² + ½γ12² per triangle (as the script's (e11² + e22²) + 0.5 γ12²)
static long strainDensity(KN<double>* const& e11, KN<double>* const& e22, KN<double>* const& g12, KN<double>* const& density) {
  const long n = density->N();
  if (e11->N() != n || e22->N() != n || g12->N() != n) ExecError("strainDensity: the arrays have different sizes");
  for (long t = 0; t < n; t++) (*density)[t] = ((*e11)[t]*(*e11)[t] + (*e22)[t]*(*e22)[t]) + 0.5*((*g12)[t]*(*g12)[t]);
  return 0;
}

static void init() {
  Global.Add("stresses", "(", new OneOperatorCode<Stresses>());
  Global.Add("strainDensity", "(", new OneOperator4_<long, KN<double>*, KN<double>*, KN<double>*, KN<double>*>(strainDensity));
}

LOADFUNC(init)
