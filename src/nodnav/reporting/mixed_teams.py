"""The report's section on mixed teams: NOD robots among people and robots of other conventions."""

from __future__ import annotations

from nodnav.experiments.statistics import fmt_mean_sd, fmt_rate
from nodnav.experiments.teams import STUDY_MIXED_TEAMS, TeamRow, team_rows
from nodnav.reporting.document import ReportDocument
from nodnav.reporting.markdown import md_table

#: Studies of docs/studies/ that this section reads, in report order.
STUDY_PEOPLE = "mixed-teams-people"
STUDY_FAMILY = "mixed-teams-family"

HEADER = ["roles", "trials", "robots arrive, no contact they caused %", "success %", "no robot touched %",
          "contacts caused by robots", "by people", "robots' makespan (s)", "delay of the trial-method robots (s)"]


def team_table(rows: list[TeamRow]) -> list[str]:
    """The rows as a Markdown table (rates in percent with Wilson 95 % intervals)."""
    return md_table(HEADER, [[r.label, r.trials, fmt_rate(r.robots_ok), fmt_rate(r.success),
                              fmt_rate(r.contact_free), r.contacts_by_robots, r.contacts_by_people,
                              fmt_mean_sd(*r.makespan), fmt_mean_sd(*r.delay)] for r in rows])


def section_mixed_teams(rep: ReportDocument,
                        studies: tuple[str, ...] = (STUDY_MIXED_TEAMS, STUDY_PEOPLE, STUDY_FAMILY)) -> None:
    """One table per study of mixed teams (docs/mixed-teams.md says what each column means);
    nothing when the database holds none of ``studies``."""
    if not any(rep.has(study) for study in studies):
        return
    rep.add("## Mixed teams", "",
            "NOD robots with a person (social force model) or a robot of another convention among them "
            "(`robots[i].method`, study key `roles`). A contact with a person is attributed to whoever moved into "
            "the other; only a robot's ends the trial.")
    for study in studies:
        if not rep.has(study):
            if study == STUDY_MIXED_TEAMS:  # the reproduce part; the other studies are optional
                rep.absent(study, "Run `nodnav reproduce --parts mixed-teams` to add it.")
            continue
        rep.add(f"### Study `{study}`", "")
        records = rep.store.records(study)
        rep.add(*team_table(team_rows(records)), "")
        if len({r.scenario for r in records}) > 1:
            rep.add("Per scenario:", "", *team_table(team_rows(records, by_scenario=True)), "")
