// Body 2 of the paper's scene (docs/model.md §8): Ω2 = (0,6)×(−6,0).
// Physical curve tags become FreeFEM boundary labels:
//   1 Γ_C (y = 0)   2 right side (x = 6)   3 bottom (y = −6)   4 left side (x = 0)
// n = number of elements along each side (h = 6/n); structured = 1 gives a transfinite mesh
// (the same with every gmsh version; every diagonal the same way, so n and 2n are nested),
// structured = 0 a frontal-Delaunay mesh with n uniform elements on Γ_C.
DefineConstant[ n = 32, structured = 1, adapted = 0 ];
// adapted = 1 (set by orchestrate adapt, with a size field): no Transfinite line, so the sizes rule.
If (n < 1 || n != Floor(n))
  Error("paper_body2.geo: n = %g must be a positive integer", n);
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
If (!adapted)
  Transfinite Curve{1} = n + 1;
EndIf
If (structured && !adapted)
  Transfinite Curve{2, 3, 4} = n + 1;
  Transfinite Surface{1} = {1, 2, 3, 4} Left;
EndIf
Physical Curve(1) = {1};
Physical Curve(2) = {2};
Physical Curve(3) = {3};
Physical Curve(4) = {4};
Physical Surface(1) = {1};
Mesh.MshFileVersion = 2.2;
Mesh.Binary = 0;
