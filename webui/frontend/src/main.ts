import "./app-shell";
