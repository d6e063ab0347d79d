// The half-cylinder of the Hertz scene (scenes/hertz.toml): the disk of radius R about (0, R) cut
// by a chord, keeping the arc of `angle` degrees centred on its lowest point (180: the half below
// the diameter y = R; less: a rounded cap). Labels: 1 the lower arc (Γ_C, touching the block at
// the origin), 2 the flat top (pressed). Size hc = 1/n within `zone` of the origin, growing linearly to hfar = ratio·hc at distance
// `reach`; the arc is meshed as a polyline through its nodes (a curved contact side, docs/model.md §10).
DefineConstant[ n = 8, R = 8, angle = 180, zone = 1.5, reach = 6, ratio = 8, adapted = 0 ];
// adapted = 1 (set by orchestrate adapt, with a size field): the size field alone sets the sizes.
If (n < 1 || n != Floor(n))
  Error("hertz_cylinder.geo: n = %g must be a positive integer", n);
  Abort;
EndIf
If (R <= zone || zone <= 0 || reach <= zone || ratio < 1)
  Error("hertz_cylinder.geo: need 0 < zone < reach, zone < R and ratio >= 1 (R = %g, zone = %g, reach = %g)", R, zone, reach);
  Abort;
EndIf
If (angle <= 0 || angle >= 360)
  Error("hertz_cylinder.geo: angle = %g must lie in (0, 360) degrees", angle);
  Abort;
EndIf
hc = 1 / n;
hfar = ratio * hc;
half = angle * Pi / 360;
Point(1) = {0, R, 0, hfar};
Point(2) = {-R * Sin(half), R - R * Cos(half), 0, hfar};
Point(3) = {0, 0, 0, hc};
Point(4) = {R * Sin(half), R - R * Cos(half), 0, hfar};
Circle(1) = {2, 1, 3};
Circle(2) = {3, 1, 4};
Line(3) = {4, 2};
Curve Loop(1) = {1, 2, 3};
Plane Surface(1) = {1};
Field[1] = Distance;
Field[1].PointsList = {3};
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
Physical Surface(1) = {1};
Mesh.MshFileVersion = 2.2;
Mesh.Binary = 0;
