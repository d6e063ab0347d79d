// A rectangle (x0,x1)×(y0,y1). Physical curve tags (FreeFEM labels):
//   1 bottom (y = y0)   2 right (x = x1)   3 top (y = y1)   4 left (x = x0)
// n = number of elements along the bottom and the top (uniform there, so that two rectangles
// sharing a side have traces that match when their n match); h = (x1 − x0)/n elsewhere.
// structured = 1 gives a transfinite mesh, structured = 0 a frontal-Delaunay one.
DefineConstant[ x0 = 0, x1 = 1, y0 = 0, y1 = 1, n = 10, structured = 0, adapted = 0 ];
// adapted = 1 (set by orchestrate adapt, with a size field): no Transfinite line, so the sizes rule.
If (n < 1 || n != Floor(n))
  Error("rectangle.geo: n = %g must be a positive integer", n);
  Abort;
EndIf
If (x1 <= x0)
  Error("rectangle.geo: x1 = %g must exceed x0 = %g", x1, x0);
  Abort;
EndIf
If (y1 <= y0)
  Error("rectangle.geo: y1 = %g must exceed y0 = %g", y1, y0);
  Abort;
EndIf
h = (x1 - x0) / n;
Point(1) = {x0, y0, 0, h};
Point(2) = {x1, y0, 0, h};
Point(3) = {x1, y1, 0, h};
Point(4) = {x0, y1, 0, h};
Line(1) = {1, 2};
Line(2) = {2, 3};
Line(3) = {3, 4};
Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
If (!adapted)
  Transfinite Curve{1, 3} = n + 1;
EndIf
If (structured && !adapted)
  Transfinite Curve{2, 4} = Ceil((y1 - y0) / h) + 1;
  Transfinite Surface{1} = {1, 2, 3, 4} Left;
EndIf
Physical Curve(1) = {1};
Physical Curve(2) = {2};
Physical Curve(3) = {3};
Physical Curve(4) = {4};
Physical Surface(1) = {1};
Mesh.MshFileVersion = 2.2;
Mesh.Binary = 0;
