// Body 1 of the paper's scene (docs/model.md §8): Ω1 = (0,6)×(0,6).
// Physical curve tags become FreeFEM boundary labels:
//   1 Γ_C (y = 0)   2 right side (x = 6)   3 top, 3 ≤ x ≤ 6   4 top, 0 ≤ x ≤ 3   5 left side (x = 0)
// The top is split at x = 3 because the paper's load jumps there; a mesh node must sit on the jump.
// n = number of elements along each side (h = 6/n). structured = 1 gives a transfinite mesh,
// which every gmsh version builds identically (n must be even: x = 3 is a node), with every
// diagonal the same way, so the meshes of n and 2n are nested (a P1 field of one is a P1 field
// of the other, and convergence studies measure errors exactly); structured = 0 gives a
// frontal-Delaunay mesh of size h with n uniform elements on Γ_C.
DefineConstant[ n = 24, structured = 1, adapted = 0 ];
// adapted = 1 (set by orchestrate adapt, with a size field): no Transfinite line, so the sizes rule.
If (n < 1 || n != Floor(n))
  Error("paper_body1.geo: n = %g must be a positive integer", n);
  Abort;
EndIf
If (structured && n % 2 == 1)
  Error("paper_body1.geo: n = %g must be even for the structured mesh (x = 3 must be a node)", n);
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
If (!adapted)
  Transfinite Curve{1} = n + 1;
EndIf
If (structured && !adapted)
  Transfinite Curve{2, 5} = n + 1;
  Transfinite Curve{3, 4} = n / 2 + 1;
  Transfinite Surface{1} = {1, 2, 3, 5} Left;
EndIf
Physical Curve(1) = {1};
Physical Curve(2) = {2};
Physical Curve(3) = {3};
Physical Curve(4) = {4};
Physical Curve(5) = {5};
Physical Surface(1) = {1};
Mesh.MshFileVersion = 2.2;
Mesh.Binary = 0;
