// The per-triangle stresses of a body at a step (docs/model.md §8; edp/lib/body.idp, bodyFigures) in
// one pass over the triangles, where the script took about 30 vector operations, each a pass of
// its own (a third of a step's work beyond the back-substitutions at h1 = 6/96):
//   real vmMax = stresses(material, zetaBar, e11, e22, g12, e11Old, e22Old, g12Old,
//                         e11Old2, e22Old2, g12Old2, s11, s22, s12, s33, vmSquared,
//                         elastic11, elastic22, elastic12)
//   material = [aG, bG, mu, eta, k, planeStrain, bdf2Rate, fields]
//   bdf2Explicit(material, zetaStarBar, ...)   the next BDF2 step's explicit stress and ε(u*):ε(u*)
//                                           (below; ε:ε = ε11² + ε22² + ½γ12² per triangle, as
//                                           strainoperators.cpp's strainsOf gives it of uⁿ)
// From the strains of uⁿ (e11 = ε11, e22 = ε22, g12 = γ12 = 2ε12, per triangle), those of uⁿ⁻¹
// and uⁿ⁻², and ζ̄ⁿ (ζ averaged on the triangle):
//   k·ε(u̇ⁿ) = d  = ε(uⁿ) − ε(uⁿ⁻¹)                      (Euler steps; bdf2's first)
//                 = 1.5 ε(uⁿ) − 2 ε(uⁿ⁻¹) + 0.5 ε(uⁿ⁻²)  (bdf2Rate = 1)
//   elastic = ζ̄ G ε(uⁿ):  elastic11 = aG ζ̄ tr ε + bG ζ̄ ε11,  elastic12 = ½ bG ζ̄ γ12
//   σ = A ε(u̇ⁿ) + ζ̄ G ε(uⁿ):  s11 = (μ/k) tr d + (η/k) d11 + elastic11,  s12 = elastic12 + (½η/k) dγ12
//   σ33 = 0 in plane stress; in plane strain (ε33 = 0) (μ/k) tr d + aG ζ̄ tr ε (aG = λ there)
//   vmSquared = σ11² + σ22² + σ33² − σ11σ22 − σ22σ33 − σ33σ11 + 3σ12²;  returns √max vmSquared.
// elastic11, elastic22, elastic12 are the stress of the next Euler step's explicit force (before a
// BDF2 step, bdf2Explicit writes over them). The stresses and
// vmSquared are written only with fields = 1 (a step whose files hold them); the largest von Mises
// norm is returned either way (the history's). Every value is
// computed with the operations, in the order, of the script it replaces, so the results are its
// own to the bit (tests/test_unchanged.py; no fused multiply-add: ff-c++ builds for generic x86-64).
#include <cmath>
#include <limits>
#include "ff++.hpp"
#include "AFunction_ext.hpp"

// A FreeFEM function of a material array and per-triangle arrays, every argument a real[int]:
// the arguments checked, then Kernel::compute(material, x, n) with x[a] the values of argument
// a > 0, each of n values. A Kernel names itself and its arguments (name, usage, materialUsage),
// counts them (arguments, materialSize) and gives its Result.
template<class Kernel>
class PerTriangle : public E_F0mps {
 public:
  typedef typename Kernel::Result Result;
  Expression argument[Kernel::arguments];
  explicit PerTriangle(const basicAC_F0& args) {
    args.SetNameParam(0, 0, 0);
    if (args.size() != Kernel::arguments) CompileError(std::string(Kernel::name()) + ": " + Kernel::usage());
    for (int a = 0; a < Kernel::arguments; a++) argument[a] = to<KN<double>*>(args[a]);
  }
  static ArrayOfaType typeargs() { return ArrayOfaType(atype<KN<double>*>(), true); }
  static E_F0* f(const basicAC_F0& args) { return new PerTriangle(args); }
  operator aType() const { return atype<Result>(); }
  AnyType operator()(Stack stack) const {
    KN<double>* v[Kernel::arguments];
    for (int a = 0; a < Kernel::arguments; a++) v[a] = GetAny<KN<double>*>((*argument[a])(stack));
    if (v[0]->N() != Kernel::materialSize)
      ExecError(std::string(Kernel::name()) + ": material = " + Kernel::materialUsage());
    const long n = v[1]->N();
    double* x[Kernel::arguments] = {0};
    for (int a = 1; a < Kernel::arguments; a++) {
      if (v[a]->N() != n) ExecError(std::string(Kernel::name()) + ": every per-triangle array must have one value per triangle");
      x[a] = &(*v[a])[0];
    }
    return SetAny<Result>(Kernel::compute(*v[0], x, n));
  }
};

struct Stresses {
  typedef double Result;
  enum { material, zetaBar, e11, e22, g12, e11Old, e22Old, g12Old, e11Old2, e22Old2, g12Old2,
         s11, s22, s12, s33, vmSquared, elastic11, elastic22, elastic12, arguments };
  enum { materialSize = 8 };
  static const char* name() { return "stresses"; }
  static const char* usage() { return "19 arguments (material, zetaBar, 9 strains, 8 results)"; }
  static const char* materialUsage() { return "[aG, bG, mu, eta, k, planeStrain, bdf2Rate, fields]"; }
  static double compute(const KN<double>& m, double* const x[], long n);
};

double Stresses::compute(const KN<double>& m, double* const x[], long n) {
  const double aG = m[0], bG = m[1], mu = m[2], eta = m[3], k = m[4];
  const bool planeStrain = m[5] != 0, bdf2Rate = m[6] != 0, fields = m[7] != 0;
  const double muk = mu/k, etak = eta/k, shear = 0.5*bG, shearRate = 0.5*eta/k;
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
    double vm = ((sxx*sxx + syy*syy) - sxx*syy) + 3*(sxy*sxy), szz = 0;
    if (planeStrain) {
      szz = muk*rateTrace + aG*zeTrace;
      vm = (vm + szz*szz) - szz*(sxx + syy);
    }
    x[elastic11][t] = el11; x[elastic22][t] = el22; x[elastic12][t] = el12;
    if (fields) {
      x[s11][t] = sxx; x[s22][t] = syy; x[s12][t] = sxy; x[vmSquared][t] = vm;
      if (planeStrain) x[s33][t] = szz;
    }
    largest = largest > vm ? largest : vm;  // FreeFEM's max of an array, NaN and all (RNM::Max)
  }
  return std::sqrt(largest);
}

// The per-triangle stress of the right-hand side of a BDF2 step n + 1 ≥ 2 (docs/model.md §9), made
// at the figures of step n from the strains of uⁿ (e11, e22, g12) and uⁿ⁻¹ (e11Old, ...) and
// ζ̄* (zetaStarBar, the triangle mean of ζ* = 2ζⁿ − ζⁿ⁻¹ clipped to [0, 1]):
//   σ* = A ε(4uⁿ − uⁿ⁻¹)/(2k) + (1 − ζ̄*) G ε(u*),  u* = 2uⁿ − uⁿ⁻¹,
//   bdf2Explicit(material, zetaStarBar, e11, e22, g12, e11Old, e22Old, g12Old, x11, x22, x12, densityStar)
//   material = [aG, bG, mu, eta, k]
// x11, x22, x12 = σ* (the step's force is Σ_T |T| σ*_T : ε_T(v), added), and densityStar = ε(u*):ε(u*),
// the next damage step's source. Each part as the script wrote it (its viscous and weakened parts
// apart, in its order), then added.
struct Bdf2Explicit {
  typedef long Result;
  enum { material, zetaStarBar, e11, e22, g12, e11Old, e22Old, g12Old, x11, x22, x12, densityStar, arguments };
  enum { materialSize = 5 };
  static const char* name() { return "bdf2Explicit"; }
  static const char* usage() { return "12 arguments (material, zetaStarBar, 6 strains, 4 results)"; }
  static const char* materialUsage() { return "[aG, bG, mu, eta, k]"; }
  static long compute(const KN<double>& m, double* const x[], long n);
};

long Bdf2Explicit::compute(const KN<double>& m, double* const x[], long n) {
  const double aG = m[0], bG = m[1], mu = m[2], eta = m[3], k = m[4];
  const double now = 2/k, before = -0.5/k, shearRate = 0.5*eta, shear = 0.5*bG;
  for (long t = 0; t < n; t++) {
    const double r11 = now*x[e11][t] + before*x[e11Old][t], r22 = now*x[e22][t] + before*x[e22Old][t];
    const double r12 = now*x[g12][t] + before*x[g12Old][t], rTrace = r11 + r22;
    const double v11 = mu*rTrace + eta*r11, v22 = mu*rTrace + eta*r22, v12 = shearRate*r12;
    const double s11 = 2*x[e11][t] + (-1.)*x[e11Old][t], s22 = 2*x[e22][t] + (-1.)*x[e22Old][t];
    const double s12 = 2*x[g12][t] + (-1.)*x[g12Old][t];
    const double w = -x[zetaStarBar][t] + 1, sTrace = s11 + s22;
    const double w11 = aG*(w*sTrace) + bG*(w*s11), w22 = aG*(w*sTrace) + bG*(w*s22), w12 = shear*(w*s12);
    x[x11][t] = v11 + w11; x[x22][t] = v22 + w22; x[x12][t] = v12 + w12;
    x[densityStar][t] = (s11*s11 + s22*s22) + 0.5*(s12*s12);
  }
  return 0L;
}

static void init() {
  Global.Add("stresses", "(", new OneOperatorCode<PerTriangle<Stresses> >());
  Global.Add("bdf2Explicit", "(", new OneOperatorCode<PerTriangle<Bdf2Explicit> >());
}

LOADFUNC(init)
