"""Results: the store, leaderboards, team reports and score cards.

``store`` (SQLite, one row per episode), ``leaderboard`` (rows, ranks), ``text`` (plain
text that fits a width), ``team_report`` (one team's own view), ``score_card`` (one
episode's card and failure report).
"""
