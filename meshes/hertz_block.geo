// The block of the Hertz scene (scenes/hertz.toml): (−w/2, w/2)×(−w, 0), its top the contact side.
// Labels: 1 top (Γ_C), 2 right, 3 bottom, 4 left. Size hc = 1/n within `zone` of the origin (where
// the cylinder touches), growing linearly to hfar = ratio·hc at distance `reach` (gmsh Distance/Threshold).
DefineConstant[ n = 8, w = 20, zone = 1.5, reach = 8, ratio = 16, adapted = 0 ];
// adapted = 1 (set by orchestrate adapt, with a size field): the size field alone sets the sizes.
If (n < 1 || n != Floor(n))
  Error("hertz_block.geo: n = %g must be a positive integer", n);
  Abort;
EndIf
If (w <= 2 * zone || zone <= 0 || reach <= zone || ratio < 1)
  Error("hertz_block.geo: need 0 < zone < reach, 2 zone < w and ratio >= 1 (w = %g, zone = %g, reach = %g)", w, zone, reach);
  Abort;
EndIf
hc = 1 / n;
hfar = ratio * hc;
Point(1) = {-w / 2, -w, 0, hfar};
Point(2) = {w / 2, -w, 0, hfar};
Point(3) = {w / 2, 0, 0, hfar};
Point(4) = {0, 0, 0, hc};
Point(5) = {-w / 2, 0, 0, hfar};
Line(1) = {3, 4};
Line(2) = {4, 5};
Line(3) = {2, 3};
Line(4) = {1, 2};
Line(5) = {5, 1};
Curve Loop(1) = {4, 3, 1, 2, 5};
Plane Surface(1) = {1};
Field[1] = Distance;
Field[1].PointsList = {4};
Field[2] = Threshold;
Field[2].InField = 1;
Field[2].SizeMin = hc;
Field[2].SizeMax = hfar;
Field[2].DistMin = zone;
Field[2].DistMax = reach;
If (!adapted)
  Background Field = 2;
EndIf
Mesh.MeshSizeFromPoints = 0;
Mesh.MeshSizeExtendFromBoundary = 0;
Physical Curve(1) = {1, 2};
Physical Curve(2) = {3};
Physical Curve(3) = {4};
Physical Curve(4) = {5};
Physical Surface(1) = {1};
Mesh.MshFileVersion = 2.2;
Mesh.Binary = 0;
