// The size field of the graded meshes (paper_body*_graded.geo include it after their geometry):
// at distance r from the nearest of the points singular[] the size is h·(r/radius)^grade, between
// hmin and h, where hmin = h·(h/radius)^(grade/(1−grade)) is the size at which an element reaches
// from the point to its own size. For a singularity r^λ with λ > 1 − grade this restores P1's
// optimal rate, error ∝ nodes^(−1/2), as n grows: the grading gets stronger with every level
// (hmin ∝ h² at grade 1/2), so these meshes are not nested. The includer defines h, grade,
// radius and singular[].
If (grade <= 0 || grade >= 1)
  Error("grade = %g: the grading exponent must lie in (0, 1)", grade);
EndIf
If (radius <= 0)
  Error("radius = %g: the grading radius must be positive", radius);
EndIf
hmin = h * (h / radius)^(grade / (1 - grade));
Field[1] = Distance;
Field[1].PointsList = {singular[]};
Field[2] = MathEval;
Field[2].F = Sprintf("Min(%.17g, Max(%.17g, %.17g*(F1/%.17g)^%.17g))", h, hmin, h, radius, grade);
Background Field = 2;
Mesh.MeshSizeFromPoints = 0;
Mesh.MeshSizeExtendFromBoundary = 0;
