// A rounded punch (scenes/punch.toml): a flat face of half-width w at y = gap, its corners rounded
// by quarter circles of radius r into vertical sides, height H above the face. Labels: 1 the face
// and the two rounded corners (Γ_C: a polyline whose projection onto a horizontal line is
// one-to-one, docs/model.md §10), 2 the top (pressed), 3 the sides; with split = 1 the corners are
// label 4 (a contact boundary of two labels, mesh.contactLabel = [1, 4]; the mesh is the same).
// Uniform size h = (2w + 2r)/n.
DefineConstant[ n = 24, w = 0.75, r = 0.5, H = 1.5, gap = 0.02, split = 0, adapted = 0 ];
// adapted = 1 (set by orchestrate adapt, with a size field): the size field alone sets the sizes.
If (n < 1 || n != Floor(n))
  Error("punch.geo: n = %g must be a positive integer", n);
  Abort;
EndIf
If (w <= 0 || r <= 0 || H <= r || gap < 0)
  Error("punch.geo: need w > 0, r > 0, H > r and gap >= 0 (w = %g, r = %g, H = %g, gap = %g)", w, r, H, gap);
  Abort;
EndIf
h = (2 * w + 2 * r) / n;
Point(1) = {-w, gap, 0, h};
Point(2) = {w, gap, 0, h};
Point(3) = {w, gap + r, 0, h};       // centre of the right corner
Point(4) = {w + r, gap + r, 0, h};
Point(5) = {w + r, gap + H, 0, h};
Point(6) = {-w - r, gap + H, 0, h};
Point(7) = {-w - r, gap + r, 0, h};
Point(8) = {-w, gap + r, 0, h};      // centre of the left corner
Line(1) = {1, 2};
Circle(2) = {2, 3, 4};
Line(3) = {4, 5};
Line(4) = {5, 6};
Line(5) = {6, 7};
Circle(6) = {7, 8, 1};
Curve Loop(1) = {1, 2, 3, 4, 5, 6};
Plane Surface(1) = {1};
If (split)
  Physical Curve(1) = {1};
  Physical Curve(4) = {6, 2};
Else
  Physical Curve(1) = {6, 1, 2};
EndIf
Physical Curve(2) = {4};
Physical Curve(3) = {3, 5};
Physical Surface(1) = {1};
Mesh.MshFileVersion = 2.2;
Mesh.Binary = 0;
