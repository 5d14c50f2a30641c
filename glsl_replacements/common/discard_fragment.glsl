// A prop that must exist but never show (the bounds proxy of an overlay volume).
discard;
