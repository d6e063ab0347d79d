// A wide base (−w/2, w/2)×(−depth, 0) whose top carries a contact zone Γ_C = (−a/2, a/2)×{0} only
// (the indentation of scenes/indentation.toml). Labels:
//   1 Γ_C (the middle of the top)   2 right side   3 bottom   4 left side   5 top outside Γ_C
// n = elements along Γ_C (uniform there); away from it the size grows to `coarse`·(a/n), with
// the mesh finer toward the edges (±a/2, 0) of the contact zone, where the stresses concentrate.
DefineConstant[ n = 8, w = 6, depth = 4, a = 1, coarse = 6, adapted = 0 ];
// adapted = 1 (set by orchestrate adapt, with a size field): no Transfinite line, so the sizes rule.
If (n < 1 || n != Floor(n))
  Error("base.geo: n = %g must be a positive integer", n);
  Abort;
EndIf
If (a <= 0 || w <= a)
  Error("base.geo: the contact zone a = %g must be positive and narrower than the base w = %g", a, w);
  Abort;
EndIf
If (depth <= 0)
  Error("base.geo: depth = %g must be positive", depth);
  Abort;
EndIf
If (coarse < 1)
  Error("base.geo: coarse = %g must be at least 1", coarse);
  Abort;
EndIf
h = a / n;
Point(1) = {-w/2, -depth, 0, coarse*h};
Point(2) = {w/2, -depth, 0, coarse*h};
Point(3) = {w/2, 0, 0, coarse*h};
Point(4) = {a/2, 0, 0, h};
Point(5) = {-a/2, 0, 0, h};
Point(6) = {-w/2, 0, 0, coarse*h};
Line(1) = {4, 5};
Line(2) = {2, 3};
Line(3) = {1, 2};
Line(4) = {6, 1};
Line(5) = {3, 4};
Line(6) = {5, 6};
Curve Loop(1) = {3, 2, 5, 1, 6, 4};
Plane Surface(1) = {1};
If (!adapted)
  Transfinite Curve{1} = n + 1;
EndIf
Field[1] = Distance;
Field[1].PointsList = {4, 5};
Field[2] = Threshold;
Field[2].InField = 1;
Field[2].SizeMin = h/2;
Field[2].SizeMax = coarse*h;
Field[2].DistMin = 0;
Field[2].DistMax = depth;
Background Field = 2;
Mesh.MeshSizeExtendFromBoundary = 0;
Physical Curve(1) = {1};
Physical Curve(2) = {2};
Physical Curve(3) = {3};
Physical Curve(4) = {4};
Physical Curve(5) = {5, 6};
Physical Surface(1) = {1};
Mesh.MshFileVersion = 2.2;
Mesh.Binary = 0;
