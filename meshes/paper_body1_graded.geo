// Body 1 of the paper's scene (labels as paper_body1.geo: 1 Γ_C, 2 right, 3 top x ≥ 3, 4 top x ≤ 3,
// 5 left), graded toward the points where the solution is singular: the clamped corners (0,0) and
// (0,6), the load jump (3,6) and the end (6,0) of Γ_C, by the power law of graded_size.geo
// (h = 6/n): at the exponent grade, but at loadedCornerGrade toward (0,6), where the clamp meets
// the loaded top and the error is largest. The edge of the contact zone (near (3.75,0)) and body
// 2's corner (6,−6) are left out: refining there cost nodes without lowering the error
// (docs/model-choices.md, "Graded meshes").
DefineConstant[ n = 6, grade = 0.3, loadedCornerGrade = 0.6, radius = 2, adapted = 0 ];
// adapted = 1 (set by orchestrate adapt, with a size field): the size field alone sets the sizes.
If (n < 1 || n != Floor(n))
  Error("paper_body1_graded.geo: n = %g must be a positive integer", n);
  Abort;
EndIf
h = 6 / n;
Point(1) = {0, 0, 0, h};
Point(2) = {6, 0, 0, h};
Point(3) = {6, 6, 0, h};
Point(4) = {3, 6, 0, h};
Point(5) = {0, 6, 0, h};
Line(1) = {1, 2};
Line(2) = {2, 3};
Line(3) = {3, 4};
Line(4) = {4, 5};
Line(5) = {5, 1};
Curve Loop(1) = {1, 2, 3, 4, 5};
Plane Surface(1) = {1};
singular[] = {1, 2, 4, 5};
grades[] = {grade, grade, grade, loadedCornerGrade};
Include "graded_size.geo";
Physical Curve(1) = {1};
Physical Curve(2) = {2};
Physical Curve(3) = {3};
Physical Curve(4) = {4};
Physical Curve(5) = {5};
Physical Surface(1) = {1};
Mesh.MshFileVersion = 2.2;
Mesh.Binary = 0;
