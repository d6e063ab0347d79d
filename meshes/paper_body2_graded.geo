// Body 2 of the paper's scene (labels as paper_body2.geo: 1 Γ_C, 2 right, 3 bottom, 4 left),
// graded toward the end (6,0) of Γ_C by the power law of graded_size.geo. Its other end (0,0)
// is left out: the error there is small (docs/model-choices.md, "Graded meshes").
DefineConstant[ n = 3, grade = 0.4, radius = 6, adapted = 0 ];
// adapted = 1 (set by orchestrate adapt, with a size field): the size field alone sets the sizes.
If (n < 1 || n != Floor(n))
  Error("paper_body2_graded.geo: n = %g must be a positive integer", n);
  Abort;
EndIf
h = 6 / n;
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
singular[] = {4};
grades[] = {grade};
Include "graded_size.geo";
Physical Curve(1) = {1};
Physical Curve(2) = {2};
Physical Curve(3) = {3};
Physical Curve(4) = {4};
Physical Surface(1) = {1};
Mesh.MshFileVersion = 2.2;
Mesh.Binary = 0;
