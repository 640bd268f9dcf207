import { applyTheme } from "./theme";
import "./app-shell";

applyTheme();
