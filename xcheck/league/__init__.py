"""How MuJoCo compares (issue 29): the boxes benchmark's definitions and published figures (:mod:`.boxes`, core:
numpy only), its runs by MuJoCo and by ours (:mod:`.run`), the league table (:mod:`.table`: Markdown, the report's
section, the figure), and every MuJoCo release on the bundled scenarios and the boxes (:mod:`.releases`)."""
