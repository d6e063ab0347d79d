// Body 2 of the paper's scene (labels as paper_body2.geo: 1 Γ_C, 2 right, 3 bottom, 4 left),
// graded toward the ends (0,0) and (6,0) of Γ_C by the power law of paper_body1_graded.geo.
DefineConstant[ n = 8, grade = 0.5, radius = 3 ];
If (grade <= 0 || grade >= 1)
  Error("grade = %g: the grading exponent must lie in (0, 1)", grade);
EndIf
If (radius <= 0)
  Error("radius = %g: the grading radius must be positive", radius);
EndIf
h = 6 / n;
hmin = h * (h / radius)^(grade / (1 - grade));
Point(1) = {0, 0, 0, h};
Point(2) = {0, -6, 0, h};
Point(3) = {6, -6, 0, h};
Point(4) = {6, 0, 0, h};
Line(1) = {4, 1};
Line(2) = {3, 4};
Line(3) = {2, 3};
Line(4) = {1, 2};
Curve Loop(1) = {1, 4, 3, 2};
Plane Surface(1) = {1};
Field[1] = Distance;
Field[1].PointsList = {1, 4};
Field[2] = MathEval;
Field[2].F = Sprintf("Min(%.17g, Max(%.17g, %.17g*(F1/%.17g)^%.17g))", h, hmin, h, radius, grade);
Background Field = 2;
Mesh.MeshSizeFromPoints = 0;
Mesh.MeshSizeExtendFromBoundary = 0;
Physical Curve(1) = {1};
Physical Curve(2) = {2};
Physical Curve(3) = {3};
Physical Curve(4) = {4};
Physical Surface(1) = {1};
Mesh.MshFileVersion = 2.2;
Mesh.Binary = 0;
