import { applyLanguage } from "./i18n";
import { applyTheme } from "./theme";
import "./app-shell";

applyTheme();
applyLanguage();
