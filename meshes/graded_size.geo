// The size field of the graded meshes (paper_body*_graded.geo include it after their geometry):
// at distance r from point singular[i] the size is h·(r/radius)^grades[i], between hmin_i and h,
// where hmin_i = h·(h/radius)^(grades[i]/(1−grades[i])) is the size at which an element reaches
// from the point to its own size; the mesh takes the smallest of these sizes. For a singularity
// r^λ with λ > 1 − grade this restores P1's optimal rate, error ∝ nodes^(−1/2), as n grows: the
// grading gets stronger with every level (hmin ∝ h² at grade 1/2), so these meshes are not
// nested. A point with a stronger singularity takes a larger grade. The includer defines h,
// radius, singular[] (point tags) and grades[] (one exponent per point).
If (#singular[] < 1 || #grades[] != #singular[])
  Error("graded_size.geo: %g grades for %g singular points (one grade a point, at least one point)",
        #grades[], #singular[]);
  Abort;
EndIf
If (radius <= 0)
  Error("radius = %g: the grading radius must be positive", radius);
  Abort;
EndIf
points = #singular[];
For i In {0 : points - 1}
  g = grades[i];
  If (g <= 0 || g >= 1)
    Error("grade = %g: the grading exponent must lie in (0, 1)", g);
    Abort;
  EndIf
  hmin = h * (h / radius)^(g / (1 - g));
  Field[i + 1] = Distance;
  Field[i + 1].PointsList = {singular[i]};
  Field[points + i + 1] = MathEval;
  Field[points + i + 1].F = Sprintf("Min(%.17g, Max(%.17g, %.17g*(F%g/%.17g)^%.17g))", h, hmin, h, i + 1, radius, g);
EndFor
Field[2 * points + 1] = Min;
Field[2 * points + 1].FieldsList = {points + 1 : 2 * points};
If (!adapted)  // the includer's constant: a size field of orchestrate adapt sets the sizes instead
  Background Field = 2 * points + 1;
EndIf
Mesh.MeshSizeFromPoints = 0;
Mesh.MeshSizeExtendFromBoundary = 0;
