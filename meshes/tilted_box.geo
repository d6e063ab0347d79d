// The box (0,2)×(0,2) cut in two by the straight line from (0, y0) to (2, y1), for the contact
// patch test on a tilted interface (scenes/tilted_patch.toml). side = 1: the part above the line,
// side = −1: the part below; the line is Γ_C. Labels: 1 Γ_C, 2 right side (x = 2), 3 top or
// bottom (y = 2 or y = 0), 4 left side (x = 0). n = elements along Γ_C, the same size elsewhere.
DefineConstant[ n = 6, y0 = 0.6, y1 = 1.4, side = 1, adapted = 0 ];
// adapted = 1 (set by orchestrate adapt, with a size field): no Transfinite line, so the sizes rule.
If (n < 1 || n != Floor(n))
  Error("tilted_box.geo: n = %g must be a positive integer", n);
  Abort;
EndIf
If (y0 <= 0 || y0 >= 2 || y1 <= 0 || y1 >= 2)
  Error("tilted_box.geo: the cut from (0, y0 = %g) to (2, y1 = %g) must stay inside the box, 0 < y0, y1 < 2", y0, y1);
  Abort;
EndIf
If (side != 1 && side != -1)
  Error("tilted_box.geo: side = %g must be 1 (above the cut) or -1 (below)", side);
  Abort;
EndIf
h = Sqrt(4 + (y1 - y0)^2) / n;
yOuter = (side > 0) ? 2 : 0;
Point(1) = {0, y0, 0, h};
Point(2) = {2, y1, 0, h};
Point(3) = {2, yOuter, 0, h};
Point(4) = {0, yOuter, 0, h};
Line(1) = {1, 2};
Line(2) = {2, 3};
Line(3) = {3, 4};
Line(4) = {4, 1};
// counter-clockwise on both sides (FreeFEM refuses triangles of negative area)
If (side > 0)
  Curve Loop(1) = {1, 2, 3, 4};
Else
  Curve Loop(1) = {-4, -3, -2, -1};
EndIf
Plane Surface(1) = {1};
If (!adapted)
  Transfinite Curve{1} = n + 1;
EndIf
Physical Curve(1) = {1};
Physical Curve(2) = {2};
Physical Curve(3) = {3};
Physical Curve(4) = {4};
Physical Surface(1) = {1};
Mesh.MshFileVersion = 2.2;
Mesh.Binary = 0;
